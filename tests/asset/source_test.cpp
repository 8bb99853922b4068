// Byte sources' options (asset/source.h): the link rate the CLI's --bandwidth takes.
#include <gtest/gtest.h>

#include "mirage/asset/source.h"

using namespace mirage;
using namespace mirage::asset;

TEST(SourceOptions, ParsesLinkRatesInDecimalUnits) {
  EXPECT_EQ(*parseBandwidth("20Mbit"), 20'000'000u);
  EXPECT_EQ(*parseBandwidth("100mbit"), 100'000'000u);
  EXPECT_EQ(*parseBandwidth("500kbit"), 500'000u);
  EXPECT_EQ(*parseBandwidth("1.5Gbit"), 1'500'000'000u);
  EXPECT_EQ(*parseBandwidth("9600bit"), 9600u);
  EXPECT_EQ(*parseBandwidth("0.5kbit"), 500u);
}

TEST(SourceOptions, RejectsOtherRatesWithOneLine) {
  for (const char* text : {"20MB", "20", "Mbit", "0Mbit", "-1Mbit", "infMbit", "nanMbit", "", "20 Mbit", "0.1bit"}) {
    auto r = parseBandwidth(text);
    ASSERT_FALSE(r.ok()) << text;
    EXPECT_NE(r.error().message.find(std::string("bandwidth '") + text + "'"), std::string::npos) << r.error().message;
    EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
  }
}
