# cmake -P script, run by the CTest test header_boundaries (tests/CMakeLists.txt): fails when a
# header in one of FOLDERS includes, directly or through any chain of other headers, a header of a
# forbidden library. Each header is run through the preprocessor alone (a one-line source file that
# includes it) with `-H`, which prints every header it opens with its include depth, so a forbidden
# one is reported together with the chain that reached it.
#
# Variables (lists are joined with "|", since CTest arguments cannot carry ";"):
#   COMPILER     the C++ compiler
#   STD_FLAG     its language-standard flag, e.g. -std=c++20
#   SOURCE_DIR   the project root (FOLDERS are relative to it)
#   WORK_DIR     a scratch folder for the one-line source files
#   FOLDERS      folders whose headers are checked; folders that do not exist are skipped, so a
#                folder can be listed before it is created
#   INCLUDES     include directories to preprocess with (those of the code that uses the headers)
#   DEFINES      preprocessor definitions, likewise
#   IMPLICIT     the compiler's own include directories, dropped from INCLUDES
#   FORBIDDEN_INCLUDES  include directories of the forbidden libraries, searched last
#                (-idirafter): a forbidden include is then found and reported with its chain
#                rather than failing as "no such file" when the users' include path lacks it
#   FORBIDDEN    regular expressions; an included path matching any of them is forbidden
#
# Headers that do not preprocess on their own (a missing include, a broken header) fail the check
# too: a header that cannot stand alone hides what it needs.

cmake_minimum_required(VERSION 3.25)

foreach(var COMPILER STD_FLAG SOURCE_DIR WORK_DIR FOLDERS FORBIDDEN)
  if(NOT DEFINED ${var} OR "${${var}}" STREQUAL "")
    message(FATAL_ERROR "CheckHeaderBoundaries: ${var} is not set")
  endif()
endforeach()

string(REPLACE "|" ";" folders "${FOLDERS}")
string(REPLACE "|" ";" includes "${INCLUDES}")
string(REPLACE "|" ";" defines "${DEFINES}")
string(REPLACE "|" ";" forbidden "${FORBIDDEN}")
string(REPLACE "|" ";" implicit "${IMPLICIT}")
string(REPLACE "|" ";" forbidden_includes "${FORBIDDEN_INCLUDES}")

set(flags ${STD_FLAG} -x c++ -E -H -o /dev/null)
list(REMOVE_DUPLICATES includes)
foreach(dir IN LISTS includes)
  if(NOT dir STREQUAL "" AND NOT dir IN_LIST implicit)
    list(APPEND flags "-I${dir}")
  endif()
endforeach()
list(REMOVE_DUPLICATES forbidden_includes)
foreach(dir IN LISTS forbidden_includes)
  if(NOT dir STREQUAL "" AND NOT dir IN_LIST implicit AND NOT dir IN_LIST includes)
    list(APPEND flags "-idirafter${dir}")
  endif()
endforeach()
foreach(def IN LISTS defines)
  if(NOT def STREQUAL "")
    list(APPEND flags "-D${def}")
  endif()
endforeach()

set(headers "")
set(checked_folders "")
foreach(folder IN LISTS folders)
  if(IS_DIRECTORY "${SOURCE_DIR}/${folder}")
    file(GLOB_RECURSE found LIST_DIRECTORIES false "${SOURCE_DIR}/${folder}/*.h"
         "${SOURCE_DIR}/${folder}/*.hpp")
    list(APPEND headers ${found})
    list(APPEND checked_folders "${folder}")
  endif()
endforeach()
list(SORT headers)
list(LENGTH headers header_count)
if(header_count EQUAL 0)
  message(FATAL_ERROR "CheckHeaderBoundaries: no headers found in ${FOLDERS}")
endif()

set(problems "")
foreach(header IN LISTS headers)
  file(RELATIVE_PATH shown "${SOURCE_DIR}" "${header}")
  # -H does not trace a header given with -include, so the header goes in a source file.
  set(stub "${WORK_DIR}/include_one_header.cpp")
  file(WRITE "${stub}" "#include \"${header}\"\n")
  execute_process(COMMAND "${COMPILER}" ${flags} "${stub}"
                  RESULT_VARIABLE result ERROR_VARIABLE trace OUTPUT_QUIET)
  string(REPLACE ";" "," trace "${trace}")
  string(REPLACE "\n" ";" lines "${trace}")
  if(NOT result EQUAL 0)
    # The compiler's messages without the -H trace.
    set(messages "")
    foreach(line IN LISTS lines)
      if(line MATCHES "^Multiple include guards")
        break()
      endif()
      if(NOT line MATCHES "^\\.+ ")
        string(APPEND messages "  ${line}\n")
      endif()
    endforeach()
    string(APPEND problems "\n${shown} does not preprocess on its own:\n${messages}")
    continue()
  endif()
  # `-H` lines: one dot per include level, a space, the path; level 1 is the header itself.
  # chain_<n> is the header open at level n; below a forbidden header nothing more is reported
  # (it is one finding).
  set(skip_below 0)
  foreach(line IN LISTS lines)
    if(NOT line MATCHES "^(\\.+) (.+)$")
      continue()
    endif()
    string(LENGTH "${CMAKE_MATCH_1}" depth)
    set(path "${CMAKE_MATCH_2}")
    if(skip_below GREATER 0 AND depth GREATER skip_below)
      continue()
    endif()
    set(skip_below 0)
    file(TO_CMAKE_PATH "${path}" path)
    set(chain_${depth} "${path}")
    foreach(pattern IN LISTS forbidden)
      if(path MATCHES "${pattern}")
        set(via "${shown}")
        math(EXPR last "${depth} - 1")
        if(last GREATER_EQUAL 2)
          foreach(level RANGE 2 ${last})
            set(step "${chain_${level}}")
            string(FIND "${step}" "${SOURCE_DIR}/" at)
            if(at EQUAL 0)
              file(RELATIVE_PATH step "${SOURCE_DIR}" "${step}")
            endif()
            string(APPEND via " -> ${step}")
          endforeach()
        endif()
        string(APPEND problems "\n${via} -> ${path}  (matches '${pattern}')")
        set(skip_below ${depth})
        break()
      endif()
    endforeach()
  endforeach()
endforeach()

if(NOT problems STREQUAL "")
  message(FATAL_ERROR
    "Headers that must stay free of these libraries include them:${problems}\n"
    "Move the include into a .cpp file or a header private to the library that owns the "
    "dependency (e.g. service/bridge/messages_dds.h, service/models/network.h).")
endif()
list(JOIN checked_folders ", " checked_list)
message(STATUS "${header_count} headers in ${checked_list}: no forbidden includes")
