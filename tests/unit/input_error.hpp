#pragma once
// Assertion for bad-input tests: the call throws InputError, and its message
// names every fragment given (the file, the field, what was wrong).
#include <initializer_list>
#include <string>

#include <gtest/gtest.h>

#include "config/errors.hpp"

namespace sg::test {

template <class F>
void expectInputError(F&& f, std::initializer_list<std::string> fragments) {
  try {
    f();
    ADD_FAILURE() << "no InputError thrown";
  } catch (const InputError& e) {
    const std::string what = e.what();
    for (const auto& fragment : fragments) {
      EXPECT_NE(what.find(fragment), std::string::npos) << "'" << fragment << "' not in: " << what;
    }
  }
}

}  // namespace sg::test
