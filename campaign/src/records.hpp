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
/// An output folder given to `caller` is a folder or does not exist yet: std::invalid_argument when it is empty,
/// io::InputError naming it when it is a file.
void requireOutputFolder(const std::string& out, const char* caller);

}  // namespace ctr::campaign::detail
