#include "progress.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>

namespace ctr::cli {

namespace {
double secondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

Progress::Style resolveStyle(Progress::Style s, bool quiet) {
  if (quiet) return Progress::Style::None;
  if (s != Progress::Style::Auto) return s;
  if (const char* e = std::getenv("CTR_PROGRESS")) {
    const std::string v = e;
    if (v == "live") return Progress::Style::Live;
    if (v == "plain") return Progress::Style::Plain;
    if (v == "none") return Progress::Style::None;
  }
  return ::isatty(::fileno(stderr)) ? Progress::Style::Live : Progress::Style::Plain;
}
}  // namespace

std::string Progress::duration(double s) {
  if (!std::isfinite(s) || s < 0) return "?";
  const long t = std::lround(s);
  char buf[32];
  if (t < 60) {
    std::snprintf(buf, sizeof buf, "%ld s", t);
  } else if (t < 3600) {
    std::snprintf(buf, sizeof buf, "%ld:%02ld", t / 60, t % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", t / 3600, (t / 60) % 60, t % 60);
  }
  return buf;
}

Progress::Progress(std::string what, std::size_t total, std::string unit, bool quiet, Style style, double period,
                   std::ostream* os)
    : what_(std::move(what)),
      unit_(std::move(unit)),
      total_(total),
      style_(resolveStyle(style, quiet)),
      period_(period),
      os_(os ? os : &std::cerr),
      t0_(std::chrono::steady_clock::now()),
      last_plain_(t0_) {
  if (const char* e = std::getenv("CTR_PROGRESS_PERIOD")) {
    const double p = std::atof(e);
    if (p > 0) period_ = p;
  }
  if (style_ == Style::None) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (total_ > 0) drawLocked(true);
  }
  ticker_ = std::thread([this] { tick(); });
}

Progress::~Progress() {
  finish();
}

void Progress::tick() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!finished_) {
    cv_.wait_for(lock, std::chrono::seconds(1));
    if (finished_) break;
    if (style_ == Style::Live || secondsSince(last_plain_) >= period_) drawLocked(false);
  }
}

std::string Progress::lineLocked() const {
  const double el = secondsSince(t0_);
  std::ostringstream s;
  s << what_ << ": " << done_ << "/" << total_ << " " << unit_ << ", elapsed " << duration(el);
  if (done_ > 0 && done_ < total_) s << ", ETA " << duration(el / static_cast<double>(done_) * (total_ - done_));
  if (!detail_.empty()) s << " (" << detail_ << ")";
  return s.str();
}

std::size_t Progress::total() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return total_;
}

std::string Progress::line() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return lineLocked();
}

void Progress::drawLocked(bool force_plain) {
  if (style_ == Style::None) return;
  const std::string l = lineLocked();
  if (style_ == Style::Live) {
    std::string pad = live_width_ > l.size() ? std::string(live_width_ - l.size(), ' ') : std::string();
    *os_ << "\r" << l << pad << std::flush;
    live_width_ = l.size();
    return;
  }
  if (force_plain || secondsSince(last_plain_) >= period_) {
    *os_ << l << "\n" << std::flush;
    last_plain_ = std::chrono::steady_clock::now();
  }
}

void Progress::advance(std::size_t n) {
  std::lock_guard<std::mutex> lock(mutex_);
  done_ += n;
  drawLocked(false);
}

void Progress::set(std::size_t done) {
  std::lock_guard<std::mutex> lock(mutex_);
  done_ = done;
  drawLocked(false);
}

void Progress::setTotal(std::size_t total) {
  std::lock_guard<std::mutex> lock(mutex_);
  total_ = total;
  drawLocked(false);
}

void Progress::setDetail(const std::string& detail) {
  std::lock_guard<std::mutex> lock(mutex_);
  detail_ = detail;
  if (style_ == Style::Live) drawLocked(false);
}

void Progress::note(const std::string& text) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (style_ == Style::None) return;
  if (style_ == Style::Live) {
    *os_ << "\r" << std::string(live_width_, ' ') << "\r" << text << "\n";
    live_width_ = 0;
    drawLocked(false);
  } else {
    *os_ << text << "\n" << std::flush;
  }
}

void Progress::finish() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (finished_) return;
    finished_ = true;
    if (style_ == Style::Live) {
      drawLocked(false);
      *os_ << "\n" << std::flush;
    } else if (style_ == Style::Plain) {
      drawLocked(true);
    }
  }
  cv_.notify_all();
  if (ticker_.joinable()) ticker_.join();
}

}  // namespace ctr::cli
