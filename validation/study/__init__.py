"""The vimd validation study (issue 4): RATTLE/SHAKE against the variational integrators and the
projected Runge-Kutta baseline, with GROMACS as reference, and (issue 9) where the variational
integrators beat RATTLE in wall time on water with interactions smooth to a chosen order. Entry point: validation/run_all.sh, which
runs `python3 -m study` from validation/ and rewrites the report (validation/report/README.md)."""
