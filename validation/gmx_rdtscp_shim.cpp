// Preloaded into Debian's gmx/gmx_d (LD_PRELOAD) on machines whose CPUID hides the rdtscp flag
// although the instruction executes (seen on Firecracker VMs): that GROMACS build uses rdtscp and
// refuses to start when the flag is missing. gmx_common.py preloads this only when
// /proc/cpuinfo lacks the flag; the shim then executes rdtscp once itself and stops GROMACS with a
// clear message if the CPU really cannot (instead of a crash later inside a run).
//
// GROMACS calls the exported gmx::CpuInfo::detect() through the PLT, so defining it here wins;
// it calls the real one and adds the rdtscp feature. The class layout mirrors GROMACS 2022's
// src/gromacs/hardware/cpuinfo.h (private members, in order); the enum value of rdtscp is looked
// up by name through the exported CpuInfo::featureString rather than assumed.
#include <dlfcn.h>
#include <unistd.h>
#include <x86intrin.h>

#include <csignal>

#include <cstdio>
#include <cstdlib>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace gmx {

class CpuInfo {
 public:
  enum class Feature : int {};
  static CpuInfo detect();
  static const std::string& featureString(Feature f);

  int support_level;
  int vendor;
  std::string brand;
  int family, model, stepping;
  std::set<Feature> features;
  std::vector<int> logical_processors;  // a vector's layout is its element type's; never read here
};

namespace {
void no_rdtscp(int) {
  static const char message[] = "gmx_rdtscp_shim: this CPU cannot execute rdtscp; Debian's GROMACS cannot run here\n";
  (void)!write(2, message, sizeof message - 1);
  _exit(1);
}
}  // namespace

CpuInfo CpuInfo::detect() {
  auto previous = std::signal(SIGILL, no_rdtscp);
  unsigned aux;
  (void)__rdtscp(&aux);
  std::signal(SIGILL, previous);

  using Detect = CpuInfo (*)();
  static auto real = reinterpret_cast<Detect>(dlsym(RTLD_NEXT, "_ZN3gmx7CpuInfo6detectEv"));
  if (real == nullptr) {
    std::fprintf(stderr, "gmx_rdtscp_shim: gmx::CpuInfo::detect not found in the GROMACS library\n");
    std::abort();
  }
  CpuInfo info = real();
  for (int f = 0; f < 256; ++f) {
    try {
      if (featureString(static_cast<Feature>(f)) == "rdtscp") {
        info.features.insert(static_cast<Feature>(f));
        return info;
      }
    } catch (const std::out_of_range&) {
      break;  // past the last feature GROMACS knows
    }
  }
  std::fprintf(stderr, "gmx_rdtscp_shim: GROMACS names no 'rdtscp' feature\n");
  std::abort();
}

}  // namespace gmx
