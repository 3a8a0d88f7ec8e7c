# A full disk, simulated: the first file vimd writes into the output directory (its write test)
# lands on /dev/full, where every write fails with ENOSPC.
mkdir -p out
ln -s /dev/full out/.vimd-write-test
