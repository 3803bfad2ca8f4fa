# Checks that the component example shown in README.md is, byte for byte, the
# file the build compiles (components/examples/lamp.cpp), so the README never
# shows code that does not build. Run with -DROOT=<source dir>.
file(READ "${ROOT}/README.md" readme)
file(READ "${ROOT}/components/examples/lamp.cpp" example)
string(FIND "${readme}" "<!-- example:begin -->\n```cpp\n" begin)
string(FIND "${readme}" "```\n<!-- example:end -->" end)
if(begin EQUAL -1 OR end EQUAL -1)
  message(FATAL_ERROR "README.md has no example:begin/example:end block")
endif()
string(LENGTH "<!-- example:begin -->\n```cpp\n" skip)
math(EXPR start "${begin} + ${skip}")
math(EXPR length "${end} - ${start}")
string(SUBSTRING "${readme}" ${start} ${length} shown)
if(NOT shown STREQUAL example)
  message(FATAL_ERROR "README.md's example differs from components/examples/lamp.cpp")
endif()
message(STATUS "README example matches components/examples/lamp.cpp")
