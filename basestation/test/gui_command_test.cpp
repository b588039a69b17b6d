// The /cairn/command service's requests: structured commands and console lines become the console's words;
// malformed ones are refused naming the field and the value.
#include "../src/gui_command.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace cairn::base {
namespace {

using nlohmann::json;
using Words = std::vector<std::string>;

// The message of the refusal of `request` ("" when it was not refused).
std::string Refusal(const json& request) {
  try {
    CommandRequestWords(request);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(CommandRequestWords, StructuredCommandsBecomeTheConsolesWords) {
  EXPECT_EQ(CommandRequestWords(json::parse(R"({"name": "stop", "robot": "r1"})")), (Words{"stop", "r1"}));
  EXPECT_EQ(CommandRequestWords(json::parse(R"({"name": "mode", "robot": "r2", "args": ["manual"]})")),
            (Words{"mode", "r2", "manual"}));
  EXPECT_EQ(CommandRequestWords(json::parse(R"({"name": "convoy", "robot": "r1", "args": ["r2", "r3"]})")),
            (Words{"convoy", "r1", "r2", "r3"}));
  EXPECT_EQ(CommandRequestWords(json::parse(R"({"name": "robots"})")), (Words{"robots"}));
}

TEST(CommandRequestWords, NumbersReadBackExactlyAndOptionsFollowTheArguments) {
  const Words words =
      CommandRequestWords(json::parse(R"({"name": "goto", "robot": "r1", "args": [12, -4.125, 0.1],
                                          "options": {"z": 3.2000000000000002, "wait": true}})"));
  ASSERT_EQ(words.size(), 8u);
  EXPECT_EQ(Words(words.begin(), words.begin() + 5), (Words{"goto", "r1", "12", "-4.125", "0.1"}));
  // nlohmann keeps object keys sorted: --wait after --z here.
  EXPECT_EQ(words[5], "--wait");
  EXPECT_EQ(words[6], "--z");
  EXPECT_EQ(std::stod(words[7]), 3.2000000000000002);
}

TEST(CommandRequestWords, AConsoleLineIsSplitAsTheConsoleSplitsIt) {
  EXPECT_EQ(CommandRequestWords(json{{"command", "  goto r1  12 4   # the dock"}}),
            (Words{"goto", "r1", "12", "4"}));
  EXPECT_EQ(CommandRequestWords(json{{"command", "# nothing"}}), Words{});
}

TEST(CommandRequestWords, MalformedRequestsNameTheFieldAndTheValue) {
  EXPECT_NE(Refusal(json::array()).find("must be an object"), std::string::npos);
  EXPECT_NE(Refusal(json::object()).find("one of \"name\""), std::string::npos);
  EXPECT_NE(Refusal(json{{"name", "stop"}, {"command", "stop r1"}}).find("one of \"name\""),
            std::string::npos);
  EXPECT_NE(Refusal(json{{"name", 3}}).find("name 3 must be a command name"), std::string::npos);
  EXPECT_NE(Refusal(json{{"name", "stop"}, {"robto", "r1"}}).find("field \"robto\" \"r1\" is not one of"),
            std::string::npos);
  EXPECT_NE(Refusal(json{{"name", "stop"}, {"robot", "r 1"}}).find("robot \"r 1\" must be one word"),
            std::string::npos);
  EXPECT_NE(Refusal(json{{"name", "stop"}, {"robot", "--all"}}).find("robot \"--all\" is not a robot id"),
            std::string::npos);
  EXPECT_NE(Refusal(json{{"name", "goto"}, {"robot", "r1"}, {"args", "12 4"}})
                .find("args \"12 4\" must be an array"),
            std::string::npos);
  EXPECT_NE(Refusal(json::parse(R"({"name": "goto", "robot": "r1", "args": [1, null]})"))
                .find("args[1] null must be a string or a number"),
            std::string::npos);
  EXPECT_NE(Refusal(json::parse(R"({"name": "goto", "robot": "r1", "args": [1, 2, "--wait"]})"))
                .find("args[2] \"--wait\" is an option"),
            std::string::npos);
  EXPECT_NE(Refusal(json::parse(R"({"name": "goto", "robot": "r1", "args": [1, 2], "options": {"Z": 1}})"))
                .find("option name \"Z\""),
            std::string::npos);
  EXPECT_NE(
      Refusal(json::parse(R"({"name": "goto", "robot": "r1", "args": [1, 2], "options": {"wait": false}})"))
          .find("options.wait false must be true"),
      std::string::npos);
  EXPECT_NE(Refusal(json::parse(R"({"name": "goto", "robot": "r1", "args": [1, 2], "options": {"z": [1]}})"))
                .find("options.z [1] must be a string or a number"),
            std::string::npos);
  EXPECT_NE(Refusal(json{{"command", 5}}).find("command 5 must be a console line"), std::string::npos);
  EXPECT_NE(Refusal(json{{"command", "stop r1"}, {"robot", "r1"}}).find("does not go with \"command\""),
            std::string::npos);
}

}  // namespace
}  // namespace cairn::base
