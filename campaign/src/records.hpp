// Helpers shared by the campaign's run and merge (not installed): files, time stamps, record formats.
#pragma once

#include <filesystem>
#include <string>

namespace ctr::campaign::detail {

/// Format tag of a unit record (OUT/units/STEM.json).
inline constexpr const char* kUnitFormat = "ctr-bench-unit/1";

/// The bytes of a file ("" when it cannot be read).
std::string readText(const std::filesystem::path& p);
/// The current UTC time, ISO 8601 ("2026-11-29T06:19:56Z").
std::string isoNow();
/// This machine's host name ("unknown" when it cannot be told).
std::string hostName();

}  // namespace ctr::campaign::detail
