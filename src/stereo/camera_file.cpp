// CAMERAS.json, the frame cameras of `dsmplan stereo --cameras` (stereo_frames.hpp,
// read_camera_file()): every key checked, the file and the key named in the error, values echoed
// at most 40 bytes.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/text.hpp"
#include "dsmplan/stereo_frames.hpp"

namespace dsmplan {

namespace {

// The JSON's keys, each checked with the file and the key named in the error.
struct JsonReader {
  const std::string& file;
  double number(const nlohmann::json& parent, const std::string& key, const std::string& where) const {
    if (!parent.contains(key)) throw InputError(file, where + "." + key, "missing");
    const nlohmann::json& value = parent[key];
    if (!value.is_number() || !std::isfinite(value.get<double>()))
      throw InputError(file, where + "." + key, "must be a finite number, got " + shown(value.dump()));
    return value.get<double>();
  }
  int integer(const nlohmann::json& parent, const std::string& key, const std::string& where) const {
    const double value = number(parent, key, where);
    if (value != std::floor(value) || value < 1 || value > 1e6)
      throw InputError(file, where + "." + key,
                       "must be a whole number of pixels >= 1, got " + shown(parent[key].dump()));
    return static_cast<int>(value);
  }
  std::vector<double> numbers(const nlohmann::json& value, size_t count, const std::string& where) const {
    if (!value.is_array() || value.size() != count)
      throw InputError(file, where,
                       "must be an array of " + std::to_string(count) + " numbers, got " + shown(value.dump()));
    std::vector<double> out;
    for (const auto& v : value) {
      if (!v.is_number() || !std::isfinite(v.get<double>()))
        throw InputError(file, where, "must hold finite numbers, got " + shown(v.dump()));
      out.push_back(v.get<double>());
    }
    return out;
  }
};

}  // namespace

CameraFile read_camera_file(const std::string& path) {
  // 64 MB: some 100,000 cameras; an endless stream is no CAMERAS.json.
  require_input_file(path, std::uint64_t{64} << 20, "a CAMERAS.json");
  std::ifstream in(path);
  if (!in) throw InputError(path, "", "cannot be opened");
  nlohmann::json root;
  try {
    root = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& error) {  // a syntax error, or a number beyond a double (fuzz_cameras)
    throw InputError(path, "", std::string("is not JSON: ") + error.what());
  }
  if (!root.is_object()) throw InputError(path, "", "must be a JSON object with crs and cameras");
  const JsonReader read{path};
  CameraFile file;
  file.path = path;
  if (!root.contains("crs") || !root["crs"].is_string() || root["crs"].get<std::string>().empty())
    throw InputError(path, "crs", "missing or not a string (e.g. \"EPSG:25832\")");
  file.crs = root["crs"].get<std::string>();
  if (root.contains("height_range")) {  // optional: estimated from a coarse pass when absent
    const std::vector<double> range = read.numbers(root["height_range"], 2, "height_range");
    if (!(range[0] < range[1]))
      throw InputError(path, "height_range", "must be [lowest, highest] with lowest < highest");
    file.has_height_range = true;
    file.min_height = range[0];
    file.max_height = range[1];
  }
  if (!root.contains("cameras") || !root["cameras"].is_array() || root["cameras"].size() < 2)
    throw InputError(path, "cameras", "must be an array of at least two cameras");
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  for (size_t i = 0; i < root["cameras"].size(); ++i) {
    const nlohmann::json& c = root["cameras"][i];
    const std::string where = "cameras[" + std::to_string(i) + "]";
    if (!c.is_object()) throw InputError(path, where, "must be an object");
    FrameCamera camera;
    if (!c.contains("image") || !c["image"].is_string())
      throw InputError(path, where + ".image", "missing or not a string");
    camera.width = read.integer(c, "width", where);
    camera.height = read.integer(c, "height", where);
    camera.fx = read.number(c, "fx", where);
    camera.fy = read.number(c, "fy", where);
    camera.cx = read.number(c, "cx", where);
    camera.cy = read.number(c, "cy", where);
    if (c.contains("distortion")) {
      const std::vector<double> k = read.numbers(c["distortion"], 5, where + ".distortion");
      for (int j = 0; j < 5; ++j) camera.distortion[j] = k[j];
    }
    if (!c.contains("rotation")) throw InputError(path, where + ".rotation", "missing");
    if (!c["rotation"].is_array() || c["rotation"].size() != 3)
      throw InputError(path, where + ".rotation", "must be a 3 x 3 array (rows), got " + shown(c["rotation"].dump()));
    for (int r = 0; r < 3; ++r) {
      const std::vector<double> row = read.numbers(c["rotation"][r], 3, where + ".rotation");
      for (int j = 0; j < 3; ++j) camera.rotation[r][j] = row[j];
    }
    if (!c.contains("center")) throw InputError(path, where + ".center", "missing");
    const std::vector<double> centre = read.numbers(c["center"], 3, where + ".center");
    camera.center = {centre[0], centre[1], centre[2]};
    try {
      check_camera(camera, where);
    } catch (const ArgumentError& error) {
      throw InputError(path, "", error.what());
    }
    std::filesystem::path image = c["image"].get<std::string>();
    if (image.is_relative()) image = folder / image;
    file.cameras.push_back(camera);
    file.images.push_back(image.string());
  }
  return file;
}

}  // namespace dsmplan
