// The requests of the /cairn/command service (the GUI's, or any Foxglove client's), turned into the words of
// a console command. Two forms:
//   structured (what the GUI sends): {"name": "goto", "robot": "r1", "args": [12.5, 4], "options":
//   {"z": 1.2}} a console line (for people calling the service by hand): {"command": "goto r1 12.5 4
//   --z 1.2"}
// Both give the words the console runs (CommandShell::Execute), so both have the CLI's semantics.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace cairn::base {

/// The command's words, its name first: the structured form's name, robot, args (numbers written to round
/// trip exactly) and options ("--KEY" then the value; `true` alone for a flag), or the line's words split as
/// the console splits them.
/// @throws std::invalid_argument naming the field and its value: not an object, neither or both of "name"
///     and "command", a field of the wrong type, an unknown field, an empty or blank word, a non-finite
///     number, an argument that is an option ("--wait" belongs in "options"), an option key that is not
///     lower-case words joined by '-'.
std::vector<std::string> CommandRequestWords(const nlohmann::json& request);

}  // namespace cairn::base
