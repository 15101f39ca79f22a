// Progress of long work on stderr (`ctr bench`, `ctr diagnose`, `ctr env build`): done/total, elapsed time and an
// estimate of the time left. On a terminal one live line is redrawn in place (every second); otherwise (a log file,
// a Slurm job's output) a plain line is printed every `period` seconds and at the end. Quiet: nothing at all.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <mutex>
#include <ostream>
#include <string>
#include <thread>

namespace ctr::cli {

class Progress {
 public:
  /// How the progress is shown: Auto picks Live when stderr is a terminal, else Plain. The environment variable
  /// CTR_PROGRESS=live|plain|none overrides Auto (tests, scripts).
  enum class Style { Auto, Live, Plain, None };

  /// `what` names the work ("bench"), `unit` the counted things ("runs"). `period`: seconds between plain lines
  /// (CTR_PROGRESS_PERIOD overrides it).
  Progress(std::string what, std::size_t total, std::string unit, bool quiet, Style style = Style::Auto,
           double period = 30.0, std::ostream* os = nullptr);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  /// Adds `n` done items (redraws the live line; a plain line when the period has passed).
  void advance(std::size_t n = 1);
  /// Sets the number of done items.
  void set(std::size_t done);
  /// Changes the total (e.g. once it is known).
  void setTotal(std::size_t total);
  /// A detail shown after the counts ("round 2: 3/11 candidates").
  void setDetail(const std::string& detail);
  /// Prints a message line without garbling the live line (quiet: nothing).
  void note(const std::string& line);
  /// Final line ("bench: 12/12 runs, elapsed 1:02"); the ticker stops. Called by the destructor if not before.
  void finish();

  std::size_t total() const;
  /// The current status line (for tests).
  std::string line() const;
  Style style() const { return style_; }

  /// "42 s", "3:07", "1:02:03".
  static std::string duration(double seconds);

 private:
  std::string lineLocked() const;
  void drawLocked(bool force_plain);
  void tick();

  std::string what_, unit_, detail_;
  std::size_t total_ = 0, done_ = 0;
  Style style_;
  double period_;
  std::ostream* os_;
  std::chrono::steady_clock::time_point t0_, last_plain_;
  bool finished_ = false;
  std::size_t live_width_ = 0;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::thread ticker_;
};

}  // namespace ctr::cli
