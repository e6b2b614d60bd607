#include "telemetry/logging.hpp"

#include <cstdlib>

#include <spdlog/sinks/stdout_color_sinks.h>

namespace sg {

std::shared_ptr<spdlog::logger> setupLogging(const std::string& name) {
  auto logger = spdlog::get(name);
  if (!logger) logger = spdlog::stderr_color_mt(name);
  logger->set_pattern("%H:%M:%S.%e %n %^%l%$ %v");
  if (const char* level = std::getenv("SG_LOG_LEVEL")) logger->set_level(spdlog::level::from_str(level));
  spdlog::set_default_logger(logger);
  spdlog::flush_every(std::chrono::seconds(1));
  return logger;
}

}  // namespace sg
