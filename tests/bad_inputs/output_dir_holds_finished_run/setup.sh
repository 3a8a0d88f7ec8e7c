# The output directory already holds a finished run (summary.json is written last, on success).
mkdir -p out
printf '{\n  "integrator": "rattle",\n  "steps": 20\n}\n' > out/summary.json
printf 'time,potential\n0,1\n' > out/energy.csv
