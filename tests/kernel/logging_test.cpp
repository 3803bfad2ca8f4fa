// The process-wide log level (peis/log.h): names, and a level set in code
// wins over PEIS_LOG.
#include "peis/log.h"

#include <catch2/catch.hpp>
#include <cstdlib>

TEST_CASE("log level names", "[unit][log]") {
  CHECK(peis::log::parseLevel("quiet") == peis::log::Level::Error);
  CHECK(peis::log::parseLevel("error") == peis::log::Level::Error);
  CHECK(peis::log::parseLevel("warn") == peis::log::Level::Warn);
  CHECK(peis::log::parseLevel("info") == peis::log::Level::Info);
  CHECK(peis::log::parseLevel("debug") == peis::log::Level::Debug);
  CHECK_FALSE(peis::log::parseLevel("loud").has_value());
  CHECK_FALSE(peis::log::parseLevel("").has_value());
}

TEST_CASE("setLevel changes the level in force; PEIS_LOG is reported", "[unit][log]") {
  const auto before = peis::log::level();
  peis::log::setLevel(peis::log::Level::Debug);
  CHECK(peis::log::level() == peis::log::Level::Debug);
  peis::log::setLevel(peis::log::Level::Warn);
  CHECK(peis::log::level() == peis::log::Level::Warn);
  peis::log::setLevel(before);

  const char* old = std::getenv("PEIS_LOG");
  const std::string saved = old ? old : "";
  ::setenv("PEIS_LOG", "debug", 1);
  CHECK(peis::log::levelFromEnvironment());
  ::setenv("PEIS_LOG", "loud", 1);
  CHECK_FALSE(peis::log::levelFromEnvironment());
  ::unsetenv("PEIS_LOG");
  CHECK_FALSE(peis::log::levelFromEnvironment());
  if (old) ::setenv("PEIS_LOG", saved.c_str(), 1);
}
