// Test helper: a Catch2 matcher for peis::Error by its code, for
// REQUIRE_THROWS_MATCHES(expr, peis::Error, peis::test::HasCode(...)).
#pragma once

#include <catch2/catch.hpp>
#include <string>

#include "peis/error.h"

namespace peis::test {

class HasCode : public Catch::MatcherBase<Error> {
 public:
  explicit HasCode(ErrorCode code) : code_(code) {}
  bool match(const Error& error) const override { return error.code() == code_; }
  std::string describe() const override {
    return std::string("has error code '") + peis::toString(code_) + "'";
  }

 private:
  ErrorCode code_;
};

}  // namespace peis::test
