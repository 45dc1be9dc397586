# Installs rangeseg into a scratch prefix, then configures, builds and runs a tiny consumer project
# and the README's C++ example (the block that starts with "// my_app.cpp"), taken from the README
# itself so that the example a user copies always compiles.
file(REMOVE_RECURSE ${WORK_DIR})
function(run)
  execute_process(COMMAND ${ARGV} RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGV}")
  endif()
endfunction()

file(READ ${SOURCE_DIR}/README.md readme)
string(FIND "${readme}" "```cpp\n// my_app.cpp" start)
if(start EQUAL -1)
  message(FATAL_ERROR "README.md has no ```cpp block starting with // my_app.cpp")
endif()
math(EXPR start "${start} + 7")
string(SUBSTRING "${readme}" ${start} -1 example)
string(FIND "${example}" "```" end)
string(SUBSTRING "${example}" 0 ${end} example)
file(WRITE ${WORK_DIR}/my_app.cpp "${example}")

run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix)
run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/consumer -B ${WORK_DIR}/build -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix
    -DCMAKE_BUILD_TYPE=Release -DMY_APP_SOURCE=${WORK_DIR}/my_app.cpp)
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(${WORK_DIR}/build/consumer)
# The same example built without CMake, with the flags of a rangeseg.pc in `pc_dir`.
find_program(pkg_config pkg-config)
function(build_with_pkg_config pc_dir output)
  execute_process(COMMAND ${CMAKE_COMMAND} -E env PKG_CONFIG_PATH=${pc_dir}
                          ${pkg_config} --cflags --libs rangeseg
                  OUTPUT_VARIABLE flags OUTPUT_STRIP_TRAILING_WHITESPACE RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "pkg-config --cflags --libs rangeseg with ${pc_dir} failed (${rc})")
  endif()
  separate_arguments(flags UNIX_COMMAND "${flags}")
  run(c++ -O1 ${WORK_DIR}/my_app.cpp ${flags} -o ${output})
endfunction()
file(GLOB_RECURSE pc_file ${WORK_DIR}/prefix/*/rangeseg.pc)
if(NOT pkg_config OR NOT pc_file)
  message(FATAL_ERROR "pkg-config or the installed rangeseg.pc not found")
endif()
get_filename_component(pc_dir "${pc_file}" DIRECTORY)
build_with_pkg_config(${pc_dir} ${WORK_DIR}/my_app_pkg_config)

# The build folder itself as the package, without an install: for CMake, and for pkg-config.
run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/consumer -B ${WORK_DIR}/build_tree -Drangeseg_DIR=${BUILD_DIR}
    -DCMAKE_BUILD_TYPE=Release -DMY_APP_SOURCE=${WORK_DIR}/my_app.cpp)
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build_tree --target consumer)
run(${WORK_DIR}/build_tree/consumer)
build_with_pkg_config(${BUILD_DIR} ${WORK_DIR}/my_app_build_tree_pkg_config)

set(data ${SOURCE_DIR}/../shared/data)
if(EXISTS ${data}/kinect/grabber_frame0.pcd AND EXISTS ${data}/depth_png/00000.png)
  run(${WORK_DIR}/build/my_app ${data}/kinect/grabber_frame0.pcd ${data}/depth_png/00000.png
      ${data}/depth_png/camera_primesense.json)
else()
  message(STATUS "../shared/data is absent: the README's example is built, not run")
endif()
