# Script-level tests run by ctest next to the GoogleTest executables.
set(PY /usr/bin/python3)
add_test(NAME e2e_mdanalysis
         COMMAND ${PY} ${CMAKE_SOURCE_DIR}/tests/e2e_mdanalysis.py $<TARGET_FILE:vimd> ${CMAKE_SOURCE_DIR}
                 ${CMAKE_BINARY_DIR}/test-e2e)
add_test(NAME cli_errors
         COMMAND bash ${CMAKE_SOURCE_DIR}/tests/cli_errors.sh $<TARGET_FILE:vimd> ${CMAKE_SOURCE_DIR}
                 ${CMAKE_BINARY_DIR}/test-cli)
add_test(NAME gromacs_energy_agreement
         COMMAND ${PY} ${CMAKE_SOURCE_DIR}/validation/gromacs_energy.py)
set_tests_properties(e2e_mdanalysis cli_errors gromacs_energy_agreement PROPERTIES ENVIRONMENT "OMP_NUM_THREADS=2")
# The validation study's --quick mode: every section with tiny runs, then its report's numbers are
# parsed and checked for sane ranges. Writes to the build tree, never to validation/report.
add_test(NAME study_quick
         COMMAND ${PY} ${CMAKE_SOURCE_DIR}/validation/check_report.py --run-quick
                 --out ${CMAKE_BINARY_DIR}/report-quick --vimd $<TARGET_FILE:vimd>)
# The two longest tests start first, so on a fresh clone, where ctest has no timings yet, they do
# not run alone at the end.
set_tests_properties(study_quick PROPERTIES TIMEOUT 900 COST 100)
set_tests_properties(gromacs_energy_agreement PROPERTIES COST 20)
# The Python module: energies and trajectories equal to the command line's bit for bit,
# errors as exceptions. Debian's python3-pytest, the module from build/python.
add_test(NAME python_module
         COMMAND ${PY} -m pytest -q -p no:cacheprovider ${CMAKE_SOURCE_DIR}/tests/python)
set_tests_properties(python_module PROPERTIES ENVIRONMENT
                     "OMP_NUM_THREADS=2;VIMD_CLI=$<TARGET_FILE:vimd>;PYTHONPATH=$<TARGET_FILE_DIR:vimd_python>")
# Frame 0 is the same whatever the integrator (the engine constrains the start once).
add_test(NAME start_state
         COMMAND bash ${CMAKE_SOURCE_DIR}/tests/start_state.sh $<TARGET_FILE:vimd> ${CMAKE_SOURCE_DIR}
                 ${CMAKE_BINARY_DIR}/test-start-state)
set_tests_properties(start_state PROPERTIES ENVIRONMENT "OMP_NUM_THREADS=2")
# A real SIGTERM to a running vimd, then --continue: the same outputs as without the stop.
add_test(NAME stop_continue
         COMMAND bash ${CMAKE_SOURCE_DIR}/tests/stop_continue.sh $<TARGET_FILE:vimd> ${CMAKE_SOURCE_DIR}
                 ${CMAKE_BINARY_DIR}/test-stop-continue)
set_tests_properties(stop_continue PROPERTIES ENVIRONMENT "OMP_NUM_THREADS=2")

# docs/run-file.md is what `vimd keys --markdown` prints (test_config checks the schema's text; this
# checks the command prints that schema).
add_test(NAME keys_markdown_is_docs
         COMMAND bash -c "\"$0\" keys --markdown | diff - \"$1\"" $<TARGET_FILE:vimd>
                 ${CMAKE_SOURCE_DIR}/docs/run-file.md)

# The bad-input catalogue: one directory per case under tests/bad_inputs, each with
# the command, exit status and message fragment it expects.
add_test(NAME bad_inputs
         COMMAND ${PY} ${CMAKE_SOURCE_DIR}/tests/bad_inputs.py $<TARGET_FILE:vimd> ${CMAKE_SOURCE_DIR}/tests/bad_inputs
                 ${CMAKE_BINARY_DIR}/test-bad-inputs)
set_tests_properties(bad_inputs PROPERTIES TIMEOUT 600)

# validation/README.md's tables are generated from validation/results/*.json: a table edited by hand,
# or a results file rerun without regenerating the README, fails here.
add_test(NAME validation_tables COMMAND ${PY} ${CMAKE_SOURCE_DIR}/validation/tables.py --check)
