// The progress reporter: what each mode prints, and that --quiet (mode None) prints nothing.
#include <algorithm>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "mirage/core/progress.h"

namespace mirage {
namespace {

// Everything a reporter wrote to its stream.
struct Capture {
  std::FILE* file = std::tmpfile();
  ~Capture() { std::fclose(file); }
  std::string text() {
    std::fflush(file);
    std::rewind(file);
    std::string s;
    for (int c; (c = std::fgetc(file)) != EOF;) s += char(c);
    return s;
  }
};

size_t count(const std::string& s, char c) { return size_t(std::count(s.begin(), s.end(), c)); }

TEST(Progress, LinesFormatShowsCountsPercentTimesAndDetail) {
  std::string s = formatProgress(ProgressMode::Lines, "verify", 40, 100, 1.2, "mesh 0 cut 39");
  EXPECT_EQ(s, "verify: 40/100 (40%), 1.2 s, ETA 1.8 s: mesh 0 cut 39");
  EXPECT_EQ(formatProgress(ProgressMode::Lines, "pvs", 7, 0, 75.0, ""), "pvs: 7, 1 min 15 s");
  EXPECT_EQ(formatProgressEnd("verify", 100, 100, 3.04, ""), "verify: done 100/100 in 3.0 s");
}

TEST(Progress, TerminalFormatHasABar) {
  std::string s = formatProgress(ProgressMode::Terminal, "verify", 50, 100, 2.0, "x");
  EXPECT_NE(s.find("[############            ]"), std::string::npos) << s;
  EXPECT_NE(s.find(" 50%  50/100  2.0 s, ETA 2.0 s  x"), std::string::npos) << s;
}

TEST(Progress, QuietPrintsNothing) {
  Capture c;
  {
    Progress p(ProgressMode::None, c.file);
    p.begin("verify", 3);
    p.advance(1, "a");
    p.callback()(3, 3, "b");
    p.end();
  }
  EXPECT_EQ(c.text(), "");
}

TEST(Progress, LinesPrintOneLinePerUpdateWithoutThrottle) {
  Capture c;
  Progress p(ProgressMode::Lines, c.file);
  p.intervalSeconds = 0.0;
  p.begin("verify", 3);
  for (int i = 0; i < 3; ++i) p.advance(1, "cut");
  p.end("ok");
  std::string s = c.text();
  EXPECT_EQ(count(s, '\n'), 1u + 3u + 1u) << s; // begin, three updates, end
  EXPECT_EQ(count(s, '\r'), 0u);
  EXPECT_NE(s.find("verify: 0/3 (0%)"), std::string::npos) << s;
  EXPECT_NE(s.find("verify: 2/3 (66%)"), std::string::npos) << s;
  EXPECT_NE(s.find("verify: done 3/3 in "), std::string::npos) << s;
  EXPECT_NE(s.find(": ok\n"), std::string::npos) << s;
}

TEST(Progress, LinesAreThrottledButFirstAndLastAlwaysPrint) {
  Capture c;
  Progress p(ProgressMode::Lines, c.file);
  p.intervalSeconds = 1e9;
  p.begin("pvs", 1000);
  for (int i = 0; i < 1000; ++i) p.update(uint64_t(i + 1), 1000, "cell");
  p.end();
  std::string s = c.text();
  EXPECT_EQ(count(s, '\n'), 2u) << s;
  EXPECT_NE(s.find("pvs: done 1000/1000"), std::string::npos) << s;
}

TEST(Progress, TerminalLineUpdatesInPlaceAndEndsWithNewline) {
  Capture c;
  {
    Progress p(ProgressMode::Terminal, c.file);
    p.intervalSeconds = 0.0;
    p.begin("verify", 2);
    p.advance(1, "a long detail that the next line is shorter than");
    p.advance(1);
    p.end();
  }
  std::string s = c.text();
  EXPECT_EQ(count(s, '\n'), 1u) << s;
  EXPECT_EQ(s.back(), '\n');
  EXPECT_GE(count(s, '\r'), 3u) << s;
}

TEST(Progress, UnfinishedTerminalLineIsEndedSoAnErrorStartsOnAFreshLine) {
  Capture c;
  {
    Progress p(ProgressMode::Terminal, c.file);
    p.begin("verify", 10);
    p.advance(1);
  }
  std::string s = c.text();
  EXPECT_EQ(s.back(), '\n');
}

TEST(Progress, BreakLineEndsTheTerminalLineBeforeAnError) {
  Capture c;
  Progress p(ProgressMode::Terminal, c.file);
  p.begin("verify", 10);
  p.advance(1);
  Progress::breakLine();
  std::fprintf(c.file, "mirage: error: x\n");
  Progress::breakLine(); // nothing on screen any more: no blank line
  p.end();
  std::string s = c.text();
  size_t error = s.find("mirage: error: x\n");
  ASSERT_NE(error, std::string::npos) << s;
  EXPECT_EQ(s[error - 1], '\n') << s;
  EXPECT_EQ(count(s, '\n'), 3u) << s; // the broken line, the error, the end line
}

} // namespace
} // namespace mirage
