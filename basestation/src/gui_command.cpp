#include "gui_command.h"

#include <cmath>
#include <stdexcept>

#include "command_table.h"

namespace cairn::base {
namespace {

using nlohmann::json;

[[noreturn]] void Refuse(const std::string& field, const json& value, const std::string& why) {
  throw std::invalid_argument("command request: " + field + " " + value.dump() + " " + why);
}

// One word of the command: a string without blanks, or a finite number written as JSON writes it (the
// shortest text that reads back as the same double, integers without a fraction).
std::string Word(const std::string& field, const json& value) {
  if (value.is_number()) {
    if (!std::isfinite(value.get<double>())) Refuse(field, value, "is not a finite number");
    return value.dump();
  }
  if (!value.is_string()) Refuse(field, value, "must be a string or a number");
  std::string word = value.get<std::string>();
  if (word.empty() || word.find_first_of(" \t\r\n") != std::string::npos) {
    Refuse(field, value, "must be one word (no blanks)");
  }
  return word;
}

bool IsOptionKey(const std::string& key) {
  if (key.empty() || key.front() == '-' || key.back() == '-') return false;
  for (char c : key) {
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-')) return false;
  }
  return true;
}

std::vector<std::string> StructuredWords(const json& request) {
  for (const auto& [key, value] : request.items()) {
    if (key != "name" && key != "robot" && key != "args" && key != "options") {
      Refuse("field \"" + key + "\"", value, "is not one of name, robot, args, options");
    }
  }
  const json& name = request.at("name");
  if (!name.is_string()) Refuse("name", name, "must be a command name (a string)");
  std::vector<std::string> words = {Word("name", name)};
  if (request.contains("robot")) {
    const json& robot = request["robot"];
    if (!robot.is_string()) Refuse("robot", robot, "must be a robot id (a string)");
    words.push_back(Word("robot", robot));
    if (words.back().front() == '-') Refuse("robot", robot, "is not a robot id");
  }
  if (request.contains("args")) {
    const json& args = request["args"];
    if (!args.is_array()) Refuse("args", args, "must be an array of strings and numbers");
    for (std::size_t i = 0; i < args.size(); ++i) {
      const std::string field = "args[" + std::to_string(i) + "]";
      words.push_back(Word(field, args[i]));
      if (words.back().rfind("--", 0) == 0) Refuse(field, args[i], "is an option: options go in \"options\"");
    }
  }
  if (request.contains("options")) {
    const json& options = request["options"];
    if (!options.is_object()) Refuse("options", options, "must be an object of option names to values");
    for (const auto& [key, value] : options.items()) {
      const std::string field = "options." + key;
      if (!IsOptionKey(key))
        Refuse("option name", key, "must be lower-case words joined by '-' (e.g. z, region)");
      words.push_back("--" + key);
      if (value.is_boolean()) {
        if (!value.get<bool>())
          Refuse(field, value, "must be true (a flag) or a value: leave a flag out instead");
        continue;
      }
      words.push_back(Word(field, value));
    }
  }
  return words;
}

}  // namespace

std::vector<std::string> CommandRequestWords(const json& request) {
  if (!request.is_object()) {
    Refuse("the request", request,
           "must be an object: {\"name\", \"robot\", \"args\", \"options\"} or {\"command\"}");
  }
  const bool structured = request.contains("name");
  if (structured == request.contains("command")) {
    Refuse("the request", request,
           "must have one of \"name\" (a structured command) or \"command\" (a console line)");
  }
  if (structured) return StructuredWords(request);
  for (const auto& [key, value] : request.items()) {
    if (key != "command")
      Refuse("field \"" + key + "\"", value, "does not go with \"command\" (a console line)");
  }
  const json& line = request["command"];
  if (!line.is_string()) Refuse("command", line, "must be a console line (a string)");
  return SplitCommandLine(line.get<std::string>());
}

}  // namespace cairn::base
