# SG_SANITIZE: AddressSanitizer + UndefinedBehaviorSanitizer for every target.
# SG_TSAN: ThreadSanitizer (cannot be combined with ASan).
# SG_BANDS_STD_THREAD (default: SG_TSAN): the row bands (vision/parallel_bands.hpp)
# run on std::threads, whose start and join TSan sees, instead of Debian's
# uninstrumented libtbb. tests/tsan/run_tsan.sh builds and runs that tree.
# SG_FUZZ: libFuzzer targets in tests/fuzz (clang only); every target is built
# with ASan + UBSan and libFuzzer's coverage instrumentation.
if(SG_SANITIZE AND SG_TSAN)
  message(FATAL_ERROR "SG_SANITIZE and SG_TSAN are mutually exclusive")
endif()
if(SG_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang" OR NOT CMAKE_C_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "SG_FUZZ needs clang (libFuzzer): configure with "
                        "-DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14")
  endif()
  if(SG_TSAN)
    message(FATAL_ERROR "SG_FUZZ and SG_TSAN are mutually exclusive")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link)
  set(SG_SANITIZE ON)
endif()
if(SG_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()
if(SG_TSAN)
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
endif()
if(SG_BANDS_STD_THREAD)
  add_compile_definitions(SG_BANDS_STD_THREAD)
endif()
