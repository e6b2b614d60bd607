# Use ccache when it is installed so repeated builds (CI, set-up script) are fast.
find_program(SG_CCACHE ccache)
if(SG_CCACHE AND NOT CMAKE_CXX_COMPILER_LAUNCHER)
  set(CMAKE_C_COMPILER_LAUNCHER "${SG_CCACHE}")
  set(CMAKE_CXX_COMPILER_LAUNCHER "${SG_CCACHE}")
endif()
