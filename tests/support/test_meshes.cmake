# The test meshes' catalog (tests/support/test_meshes.h) with tests/support/data_dir.cpp, for the tests and the
# benchmarks that run over every disk mesh (included by tests/CMakeLists.txt and bench/CMakeLists.txt).
if(NOT TARGET lipmap_test_meshes)
  add_library(lipmap_test_meshes STATIC ${CMAKE_CURRENT_LIST_DIR}/test_meshes.cpp ${CMAKE_CURRENT_LIST_DIR}/data_dir.cpp)
  target_link_libraries(lipmap_test_meshes PUBLIC lipmap_engine PRIVATE lipmap_warnings)
  # Only data_dir.cpp knows where the checkout is (the other sources then compile the same in any clone).
  set_source_files_properties(${CMAKE_CURRENT_LIST_DIR}/data_dir.cpp PROPERTIES COMPILE_DEFINITIONS
    "LIPMAP_DATA_DIR=\"${PROJECT_SOURCE_DIR}/tests/data\";LIPMAP_SOURCE_DIR=\"${PROJECT_SOURCE_DIR}\"")
endif()
