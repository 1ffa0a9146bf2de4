# The operator's bytes do not depend on the number of OpenMP threads: digilap-operator run with
# OMP_NUM_THREADS = 1 and 2 writes identical Matrix Market files.
foreach(threads 1 2)
  execute_process(COMMAND ${CMAKE_COMMAND} -E env OMP_NUM_THREADS=${threads}
                  ${APP} --quiet --shape flower --h 0.005 --out ${WORK_DIR}/threads${threads}
                  RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "digilap-operator failed with OMP_NUM_THREADS=${threads}")
  endif()
endforeach()
foreach(file L.mtx A.mtx M.mtx elements.csv)
  execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK_DIR}/threads1/${file} ${WORK_DIR}/threads2/${file}
                  RESULT_VARIABLE differ)
  if(NOT differ EQUAL 0)
    message(FATAL_ERROR "${file} differs between 1 and 2 threads")
  endif()
  message(STATUS "${file}: identical for 1 and 2 threads")
endforeach()
