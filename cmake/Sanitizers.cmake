# SG_SANITIZE: AddressSanitizer + UndefinedBehaviorSanitizer for every target.
# SG_TSAN: ThreadSanitizer (cannot be combined with ASan).
if(SG_SANITIZE AND SG_TSAN)
  message(FATAL_ERROR "SG_SANITIZE and SG_TSAN are mutually exclusive")
endif()
if(SG_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()
if(SG_TSAN)
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
endif()
