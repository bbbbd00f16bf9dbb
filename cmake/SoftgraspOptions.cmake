# Warnings and sanitizers live on an interface target; every softgrasp target links it.
add_library(softgrasp_options INTERFACE)
add_library(softgrasp::options ALIAS softgrasp_options)
target_compile_options(softgrasp_options INTERFACE
  $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align -Woverloaded-virtual -Wimplicit-fallthrough>
  $<$<COMPILE_LANGUAGE:C>:-Wall -Wextra>)
if(SOFTGRASP_WERROR)
  target_compile_options(softgrasp_options INTERFACE -Werror)
endif()
if(SOFTGRASP_SANITIZER)
  target_compile_options(softgrasp_options INTERFACE -fsanitize=${SOFTGRASP_SANITIZER} -fno-omit-frame-pointer)
  target_link_options(softgrasp_options INTERFACE -fsanitize=${SOFTGRASP_SANITIZER})
endif()
# The project root is the include root: #include "service/core/depth.h".
target_include_directories(softgrasp_options INTERFACE ${PROJECT_SOURCE_DIR})

# softgrasp_add_test(NAME name SOURCES a.cpp ... LIBS lib ... [TIMEOUT s] [LABELS l])
# Timeout is per test case (default 60 s); labels default to the test folder's name.
function(softgrasp_add_test)
  cmake_parse_arguments(T "" "NAME;TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  if(NOT T_TIMEOUT)
    set(T_TIMEOUT 60)
  endif()
  if(NOT T_LABELS)
    # Label by folder (tests/http -> "http") so a run can pick a layer: ctest -L http.
    get_filename_component(T_LABELS ${CMAKE_CURRENT_SOURCE_DIR} NAME)
  endif()
  add_executable(${T_NAME} ${T_SOURCES})
  target_link_libraries(${T_NAME} PRIVATE ${T_LIBS} GTest::gtest GTest::gmock GTest::gtest_main softgrasp::options)
  target_compile_definitions(${T_NAME} PRIVATE
    SOFTGRASP_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    SOFTGRASP_TEST_DATA_DIR="${PROJECT_SOURCE_DIR}/tests/data")
  gtest_discover_tests(${T_NAME} PROPERTIES TIMEOUT ${T_TIMEOUT} LABELS "${T_LABELS}"
                       DISCOVERY_TIMEOUT 60)
endfunction()

# Fuzzer builds instrument every library for coverage feedback; only the *_fuzzer executables
# link libFuzzer's main (tests/fuzz/CMakeLists.txt). Needs clang: CC=clang CXX=clang++.
if(SOFTGRASP_BUILD_FUZZERS)
  target_compile_options(softgrasp_options INTERFACE -fsanitize=fuzzer-no-link,address,undefined)
  target_link_options(softgrasp_options INTERFACE -fsanitize=address,undefined)
endif()
