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
