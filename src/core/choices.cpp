// Names chosen from a list (dsmplan/core.hpp): the one check of an enumerated option, for every
// face, with the nearest name when the value looks like a typo.
#include <algorithm>
#include <cctype>

#include "core/text.hpp"
#include "dsmplan/core.hpp"

namespace dsmplan {

namespace {

// Levenshtein distance of two names.
size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

}  // namespace

std::string nearest_name(const std::string& typed, const std::vector<std::string>& names) {
  // A value that differs only in case is the likeliest typo of all ("prohibited").
  for (const std::string& name : names)
    if (lower_case(name) == lower_case(typed)) return name;
  std::string best;
  size_t best_distance = std::max<size_t>(1, typed.size() / 3) + 1;
  for (const std::string& name : names) {
    const size_t d = edit_distance(lower_case(typed), lower_case(name));
    if (d < best_distance) best = name, best_distance = d;
  }
  return best;
}

std::string choice_list(const std::vector<std::string>& names) {
  std::string list;
  for (size_t i = 0; i < names.size(); ++i) list += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i];
  return list;
}

void require_choice(const std::string& field, const std::string& value, const std::vector<std::string>& names) {
  if (std::find(names.begin(), names.end(), value) != names.end()) return;
  const std::string best = nearest_name(value, names);
  throw ArgumentError(field, "must be " + choice_list(names) + ", got " + shown(value) +
                                 (best.empty() ? "" : " (did you mean " + best + "?)"));
}

}  // namespace dsmplan
