// The process-wide log level (peis/logging.h): names, and a level set in
// code wins over PEIS_LOG.
#include "peis/logging.h"

#include <catch2/catch.hpp>
#include <cstdlib>

TEST_CASE("log level names", "[unit][log]") {
  CHECK(peis::parseLogLevel("quiet") == peis::LogLevel::Error);
  CHECK(peis::parseLogLevel("error") == peis::LogLevel::Error);
  CHECK(peis::parseLogLevel("warn") == peis::LogLevel::Warn);
  CHECK(peis::parseLogLevel("info") == peis::LogLevel::Info);
  CHECK(peis::parseLogLevel("debug") == peis::LogLevel::Debug);
  CHECK_FALSE(peis::parseLogLevel("loud").has_value());
  CHECK_FALSE(peis::parseLogLevel("").has_value());
}

TEST_CASE("setLogLevel changes the level in force; PEIS_LOG is reported", "[unit][log]") {
  const auto before = peis::logLevel();
  peis::setLogLevel(peis::LogLevel::Debug);
  CHECK(peis::logLevel() == peis::LogLevel::Debug);
  peis::setLogLevel(peis::LogLevel::Warn);
  CHECK(peis::logLevel() == peis::LogLevel::Warn);
  peis::setLogLevel(before);

  const char* old = std::getenv("PEIS_LOG");
  const std::string saved = old ? old : "";
  ::setenv("PEIS_LOG", "debug", 1);
  CHECK(peis::logLevelFromEnvironment());
  ::setenv("PEIS_LOG", "loud", 1);
  CHECK_FALSE(peis::logLevelFromEnvironment());
  ::unsetenv("PEIS_LOG");
  CHECK_FALSE(peis::logLevelFromEnvironment());
  if (old) ::setenv("PEIS_LOG", saved.c_str(), 1);
}
