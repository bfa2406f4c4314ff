// The message of the penumbra::Error a call throws, for tests that check what an error names. A call
// that throws nothing, or another exception, is a test failure (and gives "").
#pragma once

#include <gtest/gtest.h>

#include <exception>
#include <string>
#include <typeinfo>

#include "penumbra/core/error.h"

namespace penumbra::test {

template <class F>
std::string error_message(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "escaped as " << typeid(e).name() << ": " << e.what();
    return "";
  }
  ADD_FAILURE() << "no error";
  return "";
}

}  // namespace penumbra::test
