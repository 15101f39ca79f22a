// Recording CSV reader/writer and atomic file writing.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "../data_sets.hpp"
#include "ctr/io/file.hpp"
#include "ctr/io/recording.hpp"
#include "ctr/io/robot_yaml.hpp"

namespace fs = std::filesystem;
using ctr::io::InputError;
using ctr::io::parseRecording;
using ctr::io::Recording;

namespace {

class TempDir {
public:
  TempDir() {
    static std::atomic<int> counter{0};
    std::random_device rd;
    path_ = fs::temp_directory_path() / ("ctr_io_csv_" + std::to_string(rd()) + "_" + std::to_string(counter++));
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  const fs::path& path() const { return path_; }

private:
  fs::path path_;
};

int countEntries(const fs::path& dir) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    (void)e;
    ++n;
  }
  return n;
}

const std::string kHeader = "alpha_1,alpha_2,beta_1,beta_2,twist_2,tip_x,tip_y,tip_z,tip_tx,tip_ty,tip_tz,time";
const std::string kRow1 = "0,0,-0.018,-0.018,0.01,0.04,0.0,0.14,0.6,0.0,0.8,0";
const std::string kRow2 = "0,0.17,-0.018,-0.018,0.11,0.045,0.004,0.14,0.6,0.05,0.8,0.1";
const std::string kRow3 = "0,0.35,-0.018,-0.018,,,,,,,,0.2";

std::string csv(const std::vector<std::string>& lines) {
  std::string out;
  for (const std::string& l : lines) out += l + "\n";
  return out;
}

struct BadCsv {
  std::string label;
  std::string text;
  int tubes;
  bool require_measurement;
  std::string key;  // column in the message ("" when none applies)
  int line;         // 0 when no line applies
  std::string phrase;
};

std::ostream& operator<<(std::ostream& os, const BadCsv& b) { return os << b.label; }

std::vector<BadCsv> badCsvs() {
  return {
      {"empty_file", "", -1, true, "", 0, "empty file"},
      {"only_comments", "# a comment\n\n   \n", -1, true, "", 0, "empty file"},
      {"header_only", csv({kHeader}), -1, true, "", 1, "no data rows"},
      {"missing_beta_column", csv({"alpha_1,alpha_2,beta_1,twist_2", "0,0,0,0"}), -1, true, "beta_2", 1,
       "missing column"},
      {"duplicate_column", csv({"alpha_1,beta_1,tip_x,tip_y,tip_z,tip_x", "0,0,1,0,0,1"}), -1, true, "tip_x", 1,
       "duplicate column (columns 3 and 6)"},
      {"non_numeric_cell", csv({kHeader, kRow1, "0,0.17,-0.018,-0.018,0.11,abc,0.004,0.14,0.6,0.05,0.8,0.1"}), -1,
       true, "tip_x", 3, "'abc' is not a number (row 2)"},
      {"nan_alpha", csv({kHeader, "0,nan,-0.018,-0.018,0.01,0.04,0.0,0.14,0.6,0.0,0.8,0"}), -1, true, "alpha_2", 2,
       "not a finite number"},
      {"inf_beta", csv({kHeader, "0,0,-inf,-0.018,0.01,0.04,0.0,0.14,0.6,0.0,0.8,0"}), -1, true, "beta_1", 2,
       "not a finite number"},
      {"inf_measurement", csv({kHeader, "0,0,-0.018,-0.018,inf,0.04,0.0,0.14,0.6,0.0,0.8,0"}), -1, true, "twist_2", 2,
       "not a finite number"},
      {"too_few_cells", csv({kHeader, kRow1, "0,0.17,-0.018"}), -1, true, "", 3, "row has 3 cells"},
      {"too_many_cells", csv({kHeader, kRow1 + ",5"}), -1, true, "", 2, "row has 13 cells"},
      {"missing_actuation_value", csv({kHeader, ",0,-0.018,-0.018,0.01,0.04,0.0,0.14,0.6,0.0,0.8,0"}), -1, true,
       "alpha_1", 2, "missing actuation value"},
      {"more_tubes_than_robot", csv({kHeader, kRow1}), 1, true, "alpha_2", 1, "robot has 1 tube"},
      {"fewer_tubes_than_robot", csv({kHeader, kRow1}), 3, true, "alpha_3", 1, "missing column"},
      {"twist_beyond_n", csv({"alpha_1,alpha_2,beta_1,beta_2,twist_3", "0,0,0,0,1"}), 2, true, "twist_3", 1,
       "robot has 2 tubes"},
      {"time_not_increasing", csv({kHeader, kRow1, kRow2, "# comment", "0,0.35,-0.018,-0.018,,,,,,,,0.1"}), -1, true,
       "time", 5, "not after the previous time"},
      {"partial_tip_columns", csv({"alpha_1,beta_1,tip_x,tip_z", "0,0,1,1"}), -1, true, "tip_y", 1,
       "tip_x, tip_y, tip_z"},
      {"partial_tangent_columns", csv({"alpha_1,beta_1,tip_tx,tip_ty", "0,0,1,0"}), -1, true, "tip_tz", 1,
       "tip_tx, tip_ty, tip_tz"},
      {"partial_tip_in_row", csv({kHeader, "0,0,-0.018,-0.018,0.01,0.04,,0.14,0.6,0.0,0.8,0"}), -1, true, "tip_y", 2,
       "give all three or none"},
      {"tangent_not_unit", csv({kHeader, kRow1, "0,0.17,-0.018,-0.018,0.11,0.045,0.004,0.14,0.1,0.0,0.1,0.1"}), -1,
       true, "tip_tx", 3, "row 2"},
      {"no_measured_columns", csv({"alpha_1,beta_1,time", "0,0,0"}), -1, true, "", 1, "no measured quantity"},
      {"no_measured_values", csv({"alpha_1,alpha_2,beta_1,beta_2,twist_2", "0,0,0,0,", "0,1,0,0,"}), -1, true, "", 1,
       "no measured value"},
      {"no_actuation_columns", csv({"tip_x,tip_y,tip_z", "0,0,0"}), -1, true, "alpha_1", 1, "no actuation columns"},
      {"zero_tubes", csv({kHeader, kRow1}), 0, true, "", 0, "0 tubes"},
  };
}

class BadRecording : public ::testing::TestWithParam<BadCsv> {};

TEST_P(BadRecording, ClearInputError) {
  const BadCsv& b = GetParam();
  try {
    parseRecording(b.text, "bad.csv", b.tubes, b.require_measurement);
    FAIL() << "no error for " << b.label;
  } catch (const InputError& e) {
    const std::string what = e.what();
    SCOPED_TRACE(what);
    EXPECT_EQ(e.file(), "bad.csv");
    EXPECT_EQ(what.rfind("bad.csv", 0), 0u);
    EXPECT_EQ(e.key(), b.key);
    if (!b.key.empty()) {
      EXPECT_NE(what.find("key '" + b.key + "'"), std::string::npos);
    }
    EXPECT_EQ(e.line(), b.line);
    if (b.line > 0) {
      EXPECT_EQ(what.rfind("bad.csv:" + std::to_string(b.line) + ": ", 0), 0u);
    }
    EXPECT_NE(what.find(b.phrase), std::string::npos);
  } catch (const std::exception& e) {
    FAIL() << "wrong exception type for " << b.label << ": " << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(Io, BadRecording, ::testing::ValuesIn(badCsvs()),
                         [](const ::testing::TestParamInfo<BadCsv>& info) { return info.param.label; });

TEST(Recording, MissingFile) {
  TempDir dir;
  const std::string path = dir.file("nope.csv");
  try {
    ctr::io::loadRecording(path);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_NE(std::string(e.what()).find("not found"), std::string::npos);
  }
  EXPECT_THROW(ctr::io::loadRecording(dir.path().string()), InputError);  // a directory
}

TEST(Recording, ParsesAllColumns) {
  const Recording rec = parseRecording(csv({kHeader, kRow1, kRow2, kRow3}), "ok.csv");
  EXPECT_EQ(rec.tubes, 2);
  ASSERT_EQ(rec.rows(), 3);
  EXPECT_TRUE(rec.warnings.empty());
  EXPECT_EQ(rec.commands[1].alpha[1], 0.17);
  EXPECT_EQ(rec.commands[2].beta[0], -0.018);
  ASSERT_TRUE(rec.hasTwist() && rec.hasTipPosition() && rec.hasTipTangent() && rec.hasTime());
  EXPECT_EQ(rec.twist.rows(), 3);
  EXPECT_EQ(rec.twist.cols(), 1);
  EXPECT_EQ(rec.twist(1, 0), 0.11);
  EXPECT_TRUE(std::isnan(rec.twist(2, 0)));
  EXPECT_EQ(rec.tip_position(1, 1), 0.004);
  EXPECT_TRUE(std::isnan(rec.tip_position(2, 2)));
  EXPECT_EQ(rec.tip_tangent(0, 2), 0.8);
  EXPECT_EQ(rec.time[2], 0.2);
}

TEST(Recording, TolerantSyntax) {
  // CRLF, BOM, comments, blank lines, spaces, trailing commas, any column order, unknown column, NaN measurement.
  const std::string text =
      "\xEF\xBB\xBF# recorded 2024\r\n"
      " beta_2 , alpha_1,temperature, alpha_2,beta_1,tip_z,tip_y,tip_x ,\r\n"
      "\r\n"
      "-0.02, 0.5, 21.0, 1.5, -0.01, 0.1, 0.2, 0.3,\r\n"
      "# paused\r\n"
      "-0.02, 0.6, 21.5, 1.6, -0.01, NaN, NaN, NaN , \r\n"
      "-0.02, 0.7, , 1.7, -0.01, 0.11, 0.21, 0.31\r\n";
  const Recording rec = parseRecording(text, "tolerant.csv");
  ASSERT_EQ(rec.rows(), 3);
  EXPECT_EQ(rec.tubes, 2);
  EXPECT_EQ(rec.commands[0].alpha[0], 0.5);
  EXPECT_EQ(rec.commands[0].alpha[1], 1.5);
  EXPECT_EQ(rec.commands[0].beta[0], -0.01);
  EXPECT_EQ(rec.commands[0].beta[1], -0.02);
  EXPECT_EQ(rec.tip_position(0, 0), 0.3);
  EXPECT_EQ(rec.tip_position(0, 2), 0.1);
  EXPECT_TRUE(std::isnan(rec.tip_position(1, 0)));
  EXPECT_EQ(rec.tip_position(2, 1), 0.21);
  EXPECT_FALSE(rec.hasTwist());
  EXPECT_FALSE(rec.hasTime());
  ASSERT_EQ(rec.warnings.size(), 1u);
  EXPECT_NE(rec.warnings[0].find("temperature"), std::string::npos);
  // The file line of each row (comments and blank lines counted), for messages about rows found after parsing.
  ASSERT_EQ(rec.lines.size(), 3u);
  EXPECT_EQ(rec.lineOf(0), 4);
  EXPECT_EQ(rec.lineOf(1), 6);
  EXPECT_EQ(rec.lineOf(2), 7);
  EXPECT_EQ(rec.lineOf(3), 0);
}

TEST(Recording, LineNumbersCountCommentsAndCrlf) {
  const std::string text = "# c\r\n" + kHeader + "\r\n# c\r\n" + kRow1 + "\r\n\r\n" +
                           "0,0.17,-0.018,-0.018,0.11,x,0.004,0.14,0.6,0.05,0.8,0.1\r\n";
  try {
    parseRecording(text, "lines.csv");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 6) << e.what();
    EXPECT_EQ(e.key(), "tip_x");
  }
}

TEST(Recording, ActuationOnly) {
  const std::string text = csv({"alpha_1,alpha_2,beta_1,beta_2", "0,0,-0.01,-0.02", "0,1,-0.01,-0.02"});
  EXPECT_THROW(parseRecording(text, "act.csv"), InputError);
  const Recording rec = parseRecording(text, "act.csv", 2, false);
  EXPECT_EQ(rec.rows(), 2);
  EXPECT_FALSE(rec.hasTwist() || rec.hasTipPosition() || rec.hasTipTangent() || rec.hasTime());
}

bool sameOrBothNaN(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

void expectSameRecording(const Recording& a, const Recording& b) {
  ASSERT_EQ(a.rows(), b.rows());
  EXPECT_EQ(a.tubes, b.tubes);
  for (int r = 0; r < a.rows(); ++r) {
    EXPECT_EQ(a.commands[r].alpha, b.commands[r].alpha);
    EXPECT_EQ(a.commands[r].beta, b.commands[r].beta);
  }
  auto same = [&](const Eigen::MatrixXd& x, const Eigen::MatrixXd& y) {
    ASSERT_EQ(x.rows(), y.rows());
    ASSERT_EQ(x.cols(), y.cols());
    for (int i = 0; i < x.rows(); ++i)
      for (int j = 0; j < x.cols(); ++j) EXPECT_TRUE(sameOrBothNaN(x(i, j), y(i, j))) << i << "," << j;
  };
  same(a.twist, b.twist);
  same(a.tip_position, b.tip_position);
  same(a.tip_tangent, b.tip_tangent);
  same(a.time, b.time);
}

TEST(Recording, LoadsSharedRecordings) {
  if (!ctr_test::haveData("recordings")) GTEST_SKIP() << ctr_test::missingData("recordings");
  const fs::path dir = ctr_test::dataPath("recordings");
  int count = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() != ".csv") continue;
    SCOPED_TRACE(e.path().string());
    ++count;
    try {
      std::string robot_path = e.path().string();
      robot_path.replace(robot_path.size() - 4, 4, ".robot.yaml");
      const ctr::Robot robot = ctr::io::loadRobot(robot_path);
      const Recording rec = ctr::io::loadRecording(e.path().string(), robot.size());
      EXPECT_EQ(rec.tubes, robot.size());
      EXPECT_GT(rec.rows(), 10);
      EXPECT_TRUE(rec.hasTipPosition());
      // The tube pairs' recordings measure everything; the 3-tube one tip positions only (its README).
      EXPECT_EQ(rec.hasTwist(), robot.size() == 2);
      EXPECT_EQ(rec.hasTipTangent(), robot.size() == 2);
      EXPECT_TRUE(rec.warnings.empty());
      // Same data after a round trip.
      const Recording back = parseRecording(ctr::io::recordingToCsv(rec), "rt.csv", robot.size());
      expectSameRecording(rec, back);
    } catch (const InputError& err) {
      ADD_FAILURE() << err.what();
    }
  }
  EXPECT_GE(count, 9);
}

TEST(Recording, RoundTripFullPrecision) {
  const double nan = std::nan("");
  Recording rec;
  rec.tubes = 3;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int rows = 20;
  rec.twist = Eigen::MatrixXd(rows, 2);
  rec.tip_position = Eigen::MatrixXd(rows, 3);
  rec.tip_tangent = Eigen::MatrixXd(rows, 3);
  rec.time = Eigen::VectorXd(rows);
  for (int r = 0; r < rows; ++r) {
    Eigen::VectorXd a(3), b(3);
    for (int i = 0; i < 3; ++i) a[i] = u(rng) * 10.0, b[i] = -std::abs(u(rng)) * 0.1;
    rec.commands.emplace_back(a, b);
    rec.twist.row(r) << u(rng), (r % 3 == 0 ? nan : 0.1 + 0.2);
    rec.tip_position.row(r) << u(rng) * 1e-3, u(rng), 1.0 / 3.0;
    Eigen::Vector3d t(u(rng), u(rng), 1.0);
    rec.tip_tangent.row(r) = t.normalized().transpose();
    if (r % 4 == 1) rec.tip_tangent.row(r).setConstant(nan);
    rec.time[r] = 0.1 * r + 1e-9;
  }
  const std::string text = ctr::io::recordingToCsv(rec);
  expectSameRecording(rec, parseRecording(text, "rt.csv", 3));

  TempDir dir;
  const std::string path = dir.file("rec.csv");
  ctr::io::saveRecording(rec, path);
  expectSameRecording(rec, ctr::io::loadRecording(path, 3));
  EXPECT_EQ(countEntries(dir.path()), 1);
}

TEST(Recording, RoundTripActuationOnly) {
  Recording rec;
  rec.tubes = 1;
  rec.commands.emplace_back(Eigen::VectorXd::Constant(1, 0.5), Eigen::VectorXd::Constant(1, -0.01));
  const std::string text = ctr::io::recordingToCsv(rec);
  EXPECT_EQ(text.substr(0, text.find('\n')), "alpha_1,beta_1");
  expectSameRecording(rec, parseRecording(text, "rt.csv", 1, false));
}

TEST(WriteFileAtomic, FailureLeavesNothingBehind) {
  TempDir dir;
  const std::string missing = dir.file("no_such_dir/out.csv");
  try {
    ctr::io::writeFileAtomic(missing, "content");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), missing);
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos);
  }
  EXPECT_FALSE(fs::exists(missing));
  EXPECT_EQ(countEntries(dir.path()), 0);

  // Target is a directory: the rename fails, and the temporary file is removed.
  fs::create_directory(dir.path() / "is_a_dir");
  EXPECT_THROW(ctr::io::writeFileAtomic(dir.file("is_a_dir"), "content"), InputError);
  EXPECT_EQ(countEntries(dir.path()), 1);
  EXPECT_TRUE(fs::is_directory(dir.path() / "is_a_dir"));
}

TEST(WriteFileAtomic, ReplacesContent) {
  TempDir dir;
  const std::string path = dir.file("a.txt");
  ctr::io::writeFileAtomic(path, "first");
  ctr::io::writeFileAtomic(path, std::string("second\0with nul", 15));
  EXPECT_EQ(ctr::io::readFile(path), std::string("second\0with nul", 15));
  EXPECT_EQ(countEntries(dir.path()), 1);
}

// Truncated and corrupted recordings: success or InputError, never anything else.
TEST(Recording, NeverCrashesOnCorruptInput) {
  const std::string good = csv({kHeader, kRow1, kRow2, kRow3});
  auto tryParse = [](const std::string& text, int tubes) {
    try {
      parseRecording(text, "fuzz.csv", tubes);
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), "fuzz.csv");
    } catch (const std::exception& e) {
      ADD_FAILURE() << "non-InputError " << e.what() << " for:\n" << text;
    }
  };
  for (std::size_t n = 0; n <= good.size(); ++n) tryParse(good.substr(0, n), -1);
  std::mt19937 rng(99);
  const std::string alphabet = ",,,\n\r#_ .-+e0123456789abnxyz\"\x01\xff";
  for (int trial = 0; trial < 3000; ++trial) {
    std::string text = good;
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int k = 0; k < edits; ++k) text[rng() % text.size()] = alphabet[rng() % alphabet.size()];
    tryParse(text, trial % 2 ? -1 : 2);
  }
  tryParse("alpha_999999,beta_999999\n0,0\n", -1);
  tryParse("alpha_99999999999999999999,beta_1\n0,0\n", -1);
}

}  // namespace
