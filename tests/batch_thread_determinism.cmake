# The spectra of a segmentation's structures (digilap-spectrum --labels, structures in parallel)
# do not depend on the number of OpenMP threads: OMP_NUM_THREADS = 1 and 2 write identical
# spectra.csv and spectra_raw.csv (real labels: the JHU white-matter atlas at 2 mm).
foreach(threads 1 2)
  execute_process(COMMAND ${CMAKE_COMMAND} -E env OMP_NUM_THREADS=${threads}
                  ${APP} --quiet --volume ${DATA}/JHU-WhiteMatter-labels-2mm.nii.gz --labels 1-12 --count 20
                  --out ${WORK_DIR}/threads${threads} OUTPUT_QUIET RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "digilap-spectrum --labels failed with OMP_NUM_THREADS=${threads}")
  endif()
endforeach()
foreach(file spectra.csv spectra_raw.csv)
  execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK_DIR}/threads1/${file} ${WORK_DIR}/threads2/${file}
                  RESULT_VARIABLE differ)
  if(NOT differ EQUAL 0)
    message(FATAL_ERROR "${file} differs between 1 and 2 threads")
  endif()
  message(STATUS "${file}: identical for 1 and 2 threads")
endforeach()
