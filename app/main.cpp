#include <cstdio>
int main() { std::puts("vimd: under construction"); return 1; }
