#pragma once
// Logging set-up, once per executable in main(). The core never logs.
#include <memory>
#include <string>

#include <spdlog/spdlog.h>

namespace sg {

// Creates the named stderr logger, makes it the default, and applies the
// level from SG_LOG_LEVEL (trace, debug, info, warn, error) when set.
std::shared_ptr<spdlog::logger> setupLogging(const std::string& name);

}  // namespace sg
