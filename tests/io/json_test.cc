#include "dfo_io/json.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <random>

#include "dfo_core/error.h"

namespace dfo::io {
namespace {

TEST(Json, NumbersUseShortestRoundTripFormAndNullForNonFinite) {
  EXPECT_EQ(FormatDouble(0.1), "0.1");
  EXPECT_EQ(FormatDouble(1.303450), "1.30345");
  EXPECT_EQ(FormatDouble(4541.0), "4541");
  EXPECT_EQ(FormatDouble(1e-7), "1e-07");
  EXPECT_EQ(FormatDouble(0.0), "0");
  EXPECT_EQ(FormatDouble(std::nan("")), "null");
  EXPECT_EQ(FormatDouble(std::numeric_limits<double>::infinity()), "null");
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-1e6, 1e6);
  for (int i = 0; i < 1000; ++i) {
    const double v = u(rng) * std::pow(10.0, static_cast<int>(rng() % 40) - 20);
    EXPECT_EQ(std::strtod(FormatDouble(v).c_str(), nullptr), v);
  }
}

TEST(Json, EscapesStrings) {
  EXPECT_EQ(JsonQuote("a\"b\\c"), "\"a\\\"b\\\\c\"");
  EXPECT_EQ(JsonQuote("line\nnext\ttab"), "\"line\\nnext\\ttab\"");
  EXPECT_EQ(JsonQuote(std::string("\x01", 1)), "\"\\u0001\"");
  EXPECT_EQ(JsonQuote("caf\xc3\xa9"), "\"caf\xc3\xa9\"");  // UTF-8 kept
}

TEST(Json, DumpsObjectsInInsertionOrder) {
  JsonValue v = JsonValue::Object();
  v.Set("num_poses", 4541);
  v.Set("ate_rmse", 1.30345);
  v.Set("missing", std::nan(""));
  v.Set("name", "orb \"slam\"");
  v.Set("ok", true);
  v.Set("none", nullptr);
  JsonValue& arr = v.Set("list", JsonValue::Array());
  arr.Push(1.5);
  arr.Push(JsonValue::Object());
  arr.Push(JsonValue::Array());
  v.Set("num_poses", 10);  // replaces in place
  EXPECT_EQ(v.Dump(),
            "{\"num_poses\":10,\"ate_rmse\":1.30345,\"missing\":null,\"name\":\"orb "
            "\\\"slam\\\"\",\"ok\":true,\"none\":null,\"list\":[1.5,{},[]]}");
  EXPECT_EQ(JsonValue::Array().Dump(2), "[]");
  JsonValue small = JsonValue::Object();
  small.Set("a", 1);
  small.Set("b", JsonValue::Array()).Push(2);
  EXPECT_EQ(small.Dump(2), "{\n  \"a\": 1,\n  \"b\": [\n    2\n  ]\n}");
  EXPECT_EQ(JsonValue(int64_t{9007199254740993}).Dump(), "9007199254740993");  // > 2^53 exact
}

TEST(Json, ParsesWhatItWritesAndStandardText) {
  JsonValue v = JsonValue::Object();
  v.Set("x", -0.125);
  v.Set("s", "tab\there \xe2\x82\xac");
  v.Set("n", nullptr);
  v.Set("big", int64_t{1305031102160407000});
  v.Set("nested", JsonValue::Array()).Push(JsonValue::Object()).Set("k", false);
  const JsonValue back = ParseJson(v.Dump(2));
  EXPECT_EQ(back.Dump(), v.Dump());
  EXPECT_EQ(back["big"].AsInt(), 1305031102160407000LL);
  EXPECT_EQ(back["x"].AsNumber(), -0.125);
  EXPECT_TRUE(back["n"].IsNull());
  EXPECT_FALSE(back["nested"][0]["k"].AsBool());

  const JsonValue w =
      ParseJson(" {\"a\" : [1, 2.5e3, -0, true, null, \"\\u00e9\\/\\ud83d\\ude00\"]} ");
  ASSERT_EQ(w["a"].size(), 6u);
  EXPECT_EQ(w["a"][1].AsNumber(), 2500.0);
  EXPECT_EQ(w["a"][5].AsString(), "\xc3\xa9/\xf0\x9f\x98\x80");
  EXPECT_TRUE(w.Has("a"));
  EXPECT_FALSE(w.Has("b"));
}

TEST(Json, ErrorsSayWhereAndWhat) {
  const auto expect_error = [](const std::string& text, const std::string& fragment) {
    try {
      ParseJson(text, "result.json");
      ADD_FAILURE() << "no error for " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("result.json:"), std::string::npos) << e.what();
    }
  };
  expect_error("{\"a\": 1,\n \"b\" 2}", "result.json:2:6");
  expect_error("[1, 2", "expected ',' or ']'");
  expect_error("{\"a\": 01}", "leading zero");
  expect_error("\"open", "unterminated string");
  expect_error("[1] x", "after the JSON value");
  expect_error("nul", "unexpected character");
  const JsonValue v = ParseJson("{\"a\": 1.5}");
  EXPECT_THROW(v["b"], InputError);
  EXPECT_THROW(v["a"].AsString(), InputError);
  EXPECT_THROW(v["a"].AsInt(), InputError);
  EXPECT_THROW(v[size_t{0}], InputError);
}

}  // namespace
}  // namespace dfo::io
