// Usage rules of the command line (apps/usage.hpp).
#include "usage.hpp"

#include <algorithm>
#include <cctype>
#include <map>

#include "dsmplan/core.hpp"

namespace dsmplan::cli {

namespace {

std::vector<std::string> long_names(const CLI::App& command) {
  std::vector<std::string> names;
  for (const CLI::Option* option : command.get_options())
    for (const std::string& name : option->get_lnames()) names.push_back(name);
  return names;
}

// The command given (argv[1]) among app's, or null.
CLI::App* command_of(CLI::App& app, int argc, char** argv) {
  if (argc < 2) return nullptr;
  for (CLI::App* command : app.get_subcommands([](CLI::App*) { return true; }))
    if (command->get_name() == argv[1]) return command;
  return nullptr;
}

}  // namespace

// An unknown command or long option, refused before parsing (CLI11 would first complain about
// a missing required option), with the nearest name when it looks like a typo.
void refuse_unknown_names(CLI::App& app, int argc, char** argv) {
  std::vector<std::string> commands;
  for (CLI::App* c : app.get_subcommands([](CLI::App*) { return true; })) commands.push_back(c->get_name());
  std::string list;
  for (const std::string& name : commands) list += (list.empty() ? "" : ", ") + name;
  if (argc < 2) throw CLI::ValidationError("a command is needed: " + list + " (dsmplan --help)");
  const std::string first = argv[1];
  if (first[0] == '-') return;  // --help, --version, or CLI11's own error
  CLI::App* command = command_of(app, argc, argv);
  if (!command) {
    const std::string best = nearest_name(first, commands);
    throw CLI::ValidationError("unknown command '" + first + "'" +
                               (best.empty() ? " (the commands: " + list + ")" : " (did you mean '" + best + "'?)"));
  }
  const std::vector<std::string> names = long_names(*command);
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg.rfind("--", 0) != 0 || arg == "--") continue;
    const std::string name = arg.substr(2, arg.find('=') == std::string::npos ? std::string::npos : arg.find('=') - 2);
    if (std::find(names.begin(), names.end(), name) != names.end()) continue;
    const std::string best = nearest_name(name, names);
    throw CLI::ValidationError("unknown option --" + name + " for " + command->get_name() +
                               (best.empty() ? " (dsmplan " + command->get_name() + " --help lists them)"
                                             : " (did you mean --" + best + "?)"));
  }
}

// A long option written with one dash ("-of glb") would be read as a short one with a value
// ("-o f"), silently: refused, with the two-dash spelling.
void refuse_single_dash_long_options(CLI::App& app, int argc, char** argv) {
  CLI::App* command = command_of(app, argc, argv);
  if (!command) return;
  const std::vector<std::string> names = long_names(*command);
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg.size() < 3 || arg[0] != '-' || arg[1] == '-' || !std::isalpha(static_cast<unsigned char>(arg[1]))) continue;
    const std::string name = arg.substr(1, arg.find('=') == std::string::npos ? std::string::npos : arg.find('=') - 1);
    if (std::find(names.begin(), names.end(), name) != names.end())
      throw CLI::ValidationError(arg + ": long options take two dashes: --" + name);
  }
}

// --of for a command that writes one format: its name (any case), else ArgumentError.
void check_single_format(const std::string& of, const std::vector<std::string>& accepted) {
  if (of.empty()) return;
  std::string lower = of;
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (std::find(accepted.begin(), accepted.end(), lower) == accepted.end())
    throw ArgumentError("--of", "this command writes " + accepted.front() + " only, got '" + of + "'");
}

std::string flag_message(const ArgumentError& error) {
  // The fields of the options structs (and parameters) that a flag of some command sets.
  static const std::map<std::string, std::string> flags = {
      {"dz", "--dz"},
      {"planner", "--planner"},
      {"objective", "--objective"},
      {"end", "--end"},
      {"firmware", "--firmware"},
      {"drone", "--drone"},
      {"altitude_frame", "--altitude-frame"},
      {"dco", "--dco"},
      {"max_error", "--max-error"},
      {"tile_size", "--tile-size"},
      {"block_tiles", "--block-tiles"},
      {"max_edge", "--max-edge"},
      {"chunk", "--corridor-chunk"},
      {"margin", "--corridor-margin"},
      {"safety", "--safety"},
      {"threads", "--threads"},
      {"refine_rounds", "--refine-rounds"},
      {"spacing", "--spacing"},
      {"pixels_per_cell", "--zoom"},
      {"window", "--window"},
      {"max_agl", "--max-agl"},
      {"snap", "--snap"},
      {"route_budget", "--route-budget"},
      {"waypoint_heights", "--waypoint-heights"},
      {"no_fly_blocking", "--no-fly-blocking"},
      {"no_fly_buffer", "--no-fly-buffer"},
      {"width", "--width"},
      {"height", "--height"},
      {"vertical_crs", "--vertical-crs"},
      {"allow_approximate_vertical", "--allow-approximate-vertical"},
      {"tileset", "--3dtiles"},
      {"fusion", "--fusion"},
      {"resolution", "--res"},
      {"keep_classes", "--classes"},
      {"drop_classes", "--drop-classes"},
      {"crs", "--crs"},
      {"band", "--band"},
      {"max_distance", "--fill-holes"},
      {"zstep", "--zstep"},
      {"resampling", "--resampling"},
      {"bounds", "--bounds"},
      {"pairs", "--pairs"},
  };
  const auto found = flags.find(error.field());
  return found == flags.end() ? error.what() : located_message("", found->second, error.problem());
}

}  // namespace dsmplan::cli
