# Project-wide warning set; -Werror when SG_WERROR is on (CI turns it on).
# sg_warnings is an INTERFACE target every project target links, so third-party
# code compiled from headers keeps its own flags.
add_library(sg_warnings INTERFACE)
target_compile_options(sg_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast
  -Wcast-align -Woverloaded-virtual -Wdouble-promotion
  -Wformat=2 -Wimplicit-fallthrough)
if(SG_WERROR)
  target_compile_options(sg_warnings INTERFACE -Werror)
endif()
