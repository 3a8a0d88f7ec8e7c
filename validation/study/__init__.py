"""The vimd validation study (issue 4): RATTLE/SHAKE against the variational integrators and the
projected Runge-Kutta baseline, with GROMACS as reference. Entry point: validation/run_all.sh, which
runs `python3 -m study` from validation/ and rewrites the report (validation/report/README.md)."""
