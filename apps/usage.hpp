// The command line's usage rules, shared by every command: unknown commands and options refused
// with the nearest name, long options written with one dash refused, single-format --of checked.
// Each throws CLI::ValidationError (a usage error: one line, exit 2) or ArgumentError.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"

namespace dsmplan::cli {

/// An unknown command or long option on the command line, refused before parsing (CLI11 would
/// first complain of a missing required option), with the nearest name.
void refuse_unknown_names(CLI::App& app, int argc, char** argv);
/// "-of glb" would be read as "-o f": a long option's name after one dash is refused.
void refuse_single_dash_long_options(CLI::App& app, int argc, char** argv);
/// --of of a command that writes one format: one of `accepted` (any case), else ArgumentError.
void check_single_format(const std::string& of, const std::vector<std::string>& accepted);
/// The line the CLI prints for an ArgumentError: the library's field shown as the flag that sets
/// it ("pixels_per_cell: ..." -> "--zoom: ..."); a field no flag sets, or a flag, as it is.
std::string flag_message(const dsmplan::ArgumentError& error);

}  // namespace dsmplan::cli
