# Checks that the component example shown in README.md is, byte for byte, the
# files the build compiles: components/examples/lamp.cpp and its
# CMakeLists.txt (which the packaging test also builds against the installed
# package), so the README never shows code or a build that does not work.
# Run with -DROOT=<source dir>.
file(READ "${ROOT}/README.md" readme)

# check_block(<marker> <language> <file>): the README's block between
# <!-- marker:begin --> and <!-- marker:end --> is exactly <file>.
function(check_block marker language file)
  file(READ "${ROOT}/${file}" expected)
  set(open "<!-- ${marker}:begin -->\n```${language}\n")
  string(FIND "${readme}" "${open}" begin)
  string(FIND "${readme}" "```\n<!-- ${marker}:end -->" end)
  if(begin EQUAL -1 OR end EQUAL -1)
    message(FATAL_ERROR "README.md has no ${marker}:begin/${marker}:end block")
  endif()
  string(LENGTH "${open}" skip)
  math(EXPR start "${begin} + ${skip}")
  math(EXPR length "${end} - ${start}")
  if(length LESS 0)
    message(FATAL_ERROR "README.md's ${marker}:end comes before its ${marker}:begin")
  endif()
  string(SUBSTRING "${readme}" ${start} ${length} shown)
  if(NOT shown STREQUAL expected)
    message(FATAL_ERROR "README.md's ${marker} block differs from ${file}")
  endif()
  message(STATUS "README's ${marker} block matches ${file}")
endfunction()

check_block(example cpp components/examples/lamp.cpp)
check_block(example-build cmake components/examples/CMakeLists.txt)
