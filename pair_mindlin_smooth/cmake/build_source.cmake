# Writes OUT, a JSON record of the commit SOURCE_DIR is at and whether its
# tracked files differ from it (null and null outside a git checkout); run at
# every build (CMakeLists.txt, target build_source), so that the record
# follows the tree rather than the first configure.
set(commit "null")
set(modified "null")
find_package(Git QUIET)
if(GIT_FOUND AND EXISTS "${SOURCE_DIR}/.git")
  execute_process(COMMAND "${GIT_EXECUTABLE}" rev-parse HEAD
    WORKING_DIRECTORY "${SOURCE_DIR}"
    OUTPUT_VARIABLE head OUTPUT_STRIP_TRAILING_WHITESPACE
    RESULT_VARIABLE head_rc ERROR_QUIET)
  execute_process(COMMAND "${GIT_EXECUTABLE}" status --porcelain --untracked-files=no
    WORKING_DIRECTORY "${SOURCE_DIR}"
    OUTPUT_VARIABLE changes RESULT_VARIABLE status_rc ERROR_QUIET)
  if(head_rc EQUAL 0 AND status_rc EQUAL 0)
    set(commit "\"${head}\"")
    if(changes STREQUAL "")
      set(modified "false")
    else()
      set(modified "true")
    endif()
  endif()
endif()
file(WRITE "${OUT}" "{\"commit\": ${commit}, \"modified\": ${modified}}\n")
