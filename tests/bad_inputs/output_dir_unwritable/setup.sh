# The output directory cannot be created: its path runs through a regular file. (chmod would not
# do: CI runs as root, and root writes through permissions.)
printf 'not a directory\n' > blocker
ln -s blocker/out out
