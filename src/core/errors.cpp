// Error messages and progress reporting shared by every stage (see dsmplan/core.hpp).
#include <algorithm>

#include "dsmplan/core.hpp"

namespace dsmplan {

std::string located_message(const std::string& file, const std::string& place, const std::string& problem) {
  std::string message;
  for (const std::string* part : {&file, &place}) {
    if (!part->empty()) message.append(*part).append(": ");
  }
  message += problem;
  // One line, always: a message that spans lines breaks logs and the one-line contract.
  std::replace(message.begin(), message.end(), '\n', ' ');
  return message;
}

void report(const Progress& progress, double fraction) {
  if (progress && !progress(std::clamp(fraction, 0.0, 1.0))) throw Cancelled();
}

Progress sub_progress(const Progress& parent, double begin, double end) {
  if (!parent) return {};
  return [parent, begin, end](double fraction) { return parent(begin + (end - begin) * fraction); };
}

}  // namespace dsmplan
