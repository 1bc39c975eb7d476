// DJI WPML missions (.kmz). Placeholder: written by the WPML helper.
#include "dsmplan/export.hpp"

namespace dsmplan {

void write_wpml_kmz(const Mission&, const MissionOptions&, const std::string& path) {
  throw OutputError(path, "DJI WPML is not written yet");
}

}  // namespace dsmplan
