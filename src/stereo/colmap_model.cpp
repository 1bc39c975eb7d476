// COLMAP's text model (cameras.txt, images.txt) into frame cameras (dsmplan/colmap_model.hpp is
// the manual). The format: COLMAP's "Output Format" (https://colmap.github.io/format.html,
// doc/format.rst) and its reader ReadImagesText() (src/colmap/scene/reconstruction_io_text.cc:
// after an image's line the next line is its 2D points, even when empty); the models' parameters
// and distortion: src/colmap/sensor/models.h (SimpleRadial-, Radial-, OpenCV- and
// FullOpenCVCameraModel::Distortion); the pixel convention (centre of the top-left pixel at
// (0.5, 0.5)): doc/cameras.rst, "Projection".
#include "dsmplan/colmap_model.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "core/text.hpp"

namespace dsmplan {

namespace {

// A text model's line, split on whitespace, with the file and line for its errors.
struct ModelLine {
  const std::string& file;
  int number = 0;
  std::vector<std::string> fields;
  std::string place() const { return "line " + std::to_string(number); }
  double real(std::size_t i, const char* name) const {
    const std::string& text = fields[i];
    std::size_t used = 0;
    double value = 0;
    try {
      value = std::stod(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != text.size() || !std::isfinite(value))
      throw InputError(file, place(), std::string(name) + " must be a finite number, got " + shown(text));
    return value;
  }
  long long whole(std::size_t i, const char* name, long long least) const {
    const double value = real(i, name);
    if (value != std::floor(value) || value < least || value > 1e15)
      throw InputError(
          file, place(),
          std::string(name) + " must be a whole number >= " + std::to_string(least) + ", got " + shown(fields[i]));
    return static_cast<long long>(value);
  }
};

std::vector<std::string> split_fields(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> fields;
  for (std::string field; in >> field;) fields.push_back(field);
  return fields;
}

bool is_comment(const std::string& line) {
  const auto first = line.find_first_not_of(" \t\r");
  return first == std::string::npos || line[first] == '#';
}

std::ifstream open_model_file(const std::string& dir, const char* name) {
  const std::string path = (std::filesystem::path(dir) / name).string();
  require_input_file(path);
  std::ifstream in(path);
  if (!in) {
    const std::string binary = (std::filesystem::path(dir) / (std::string(name, 0, 7) + ".bin")).string();
    if (std::filesystem::exists(binary))
      throw InputError(path, "",
                       "missing; the model is binary: convert it with `colmap model_converter --input_path " + dir +
                           " --output_path " + dir + " --output_type TXT`");
    throw InputError(path, "", "missing or cannot be opened (a COLMAP text model has cameras.txt and images.txt)");
  }
  return in;
}

// COLMAP's parameters of `model` into ours: how many, and where each goes.
struct ModelLayout {
  const char* name;
  std::size_t params;
  bool one_focal;
  int distortion_terms;  // COLMAP's extra parameters after the principal point, in our k1, k2, p1, p2, k3 order
};
constexpr ModelLayout kModels[] = {{"SIMPLE_PINHOLE", 3, true, 0}, {"PINHOLE", 4, false, 0},
                                   {"SIMPLE_RADIAL", 4, true, 1},  {"RADIAL", 5, true, 2},
                                   {"OPENCV", 8, false, 4},        {"FULL_OPENCV", 12, false, 5}};

FrameCamera parse_camera(const ModelLine& line) {
  const std::string& model = line.fields[1];
  const ModelLayout* layout = nullptr;
  for (const ModelLayout& m : kModels)
    if (model == m.name) layout = &m;
  if (!layout)
    throw InputError(line.file, line.place(),
                     "camera model " + shown(model) +
                         " cannot be written as dsmplan's pinhole with Brown-Conrady distortion (SIMPLE_PINHOLE, "
                         "PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV are): make PINHOLE images with `colmap "
                         "image_undistorter`");
  if (line.fields.size() != 4 + layout->params)
    throw InputError(line.file, line.place(),
                     model + " needs CAMERA_ID MODEL WIDTH HEIGHT and " + std::to_string(layout->params) +
                         " parameters, got " + std::to_string(line.fields.size()) + " fields");
  FrameCamera camera;
  camera.width = static_cast<int>(line.whole(2, "WIDTH", 1));
  camera.height = static_cast<int>(line.whole(3, "HEIGHT", 1));
  std::vector<double> p;
  for (std::size_t i = 4; i < line.fields.size(); ++i) p.push_back(line.real(i, "a parameter"));
  const std::size_t c = layout->one_focal ? 1 : 2;  // index of cx
  camera.fx = p[0];
  camera.fy = layout->one_focal ? p[0] : p[1];
  camera.cx = p[c] - 0.5;  // COLMAP's pixel centres at half-integers, ours at integers
  camera.cy = p[c + 1] - 0.5;
  for (int k = 0; k < layout->distortion_terms; ++k) camera.distortion[k] = p[c + 2 + k];
  if (layout->params == 12 && (p[9] != 0 || p[10] != 0 || p[11] != 0))
    throw InputError(line.file, line.place(),
                     "FULL_OPENCV with k4, k5, k6 not 0 (a rational distortion) cannot be written as dsmplan's "
                     "Brown-Conrady k1, k2, p1, p2, k3: make PINHOLE images with `colmap image_undistorter`");
  return camera;
}

std::map<long long, FrameCamera> read_cameras_txt(const std::string& dir) {
  std::ifstream in = open_model_file(dir, "cameras.txt");
  const std::string path = (std::filesystem::path(dir) / "cameras.txt").string();
  std::map<long long, FrameCamera> cameras;
  std::string text;
  for (int number = 1; std::getline(in, text); ++number) {
    if (is_comment(text)) continue;
    const ModelLine line{path, number, split_fields(text)};
    if (line.fields.size() < 4)
      throw InputError(
          path, line.place(),
          "needs CAMERA_ID MODEL WIDTH HEIGHT PARAMS[], got " + std::to_string(line.fields.size()) + " fields");
    const long long id = line.whole(0, "CAMERA_ID", 0);
    if (!cameras.emplace(id, parse_camera(line)).second)
      throw InputError(path, line.place(), "CAMERA_ID " + std::to_string(id) + " given twice");
  }
  return cameras;
}

// R of a Hamilton quaternion (w, x, y, z), normalised first.
Mat3 quaternion_rotation(const ModelLine& line) {
  double w = line.real(1, "QW"), x = line.real(2, "QX"), y = line.real(3, "QY"), z = line.real(4, "QZ");
  const double norm = std::sqrt(w * w + x * x + y * y + z * z);
  if (!(std::abs(norm - 1) <= 1e-3))
    throw InputError(line.file, line.place(),
                     "the quaternion QW QX QY QZ has length " + short_number(norm) + ", not 1");
  w /= norm, x /= norm, y /= norm, z /= norm;
  return {{{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
           {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
           {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}}};
}

ColmapImage parse_image(const ModelLine& line, const std::map<long long, FrameCamera>& cameras) {
  ColmapImage image;
  image.id = line.whole(0, "IMAGE_ID", 0);
  const long long camera_id = line.whole(8, "CAMERA_ID", 0);
  const auto camera = cameras.find(camera_id);
  if (camera == cameras.end())
    throw InputError(line.file, line.place(), "CAMERA_ID " + std::to_string(camera_id) + " is not in cameras.txt");
  image.camera = camera->second;
  image.camera.rotation = quaternion_rotation(line);
  const Vec3 t{line.real(5, "TX"), line.real(6, "TY"), line.real(7, "TZ")};
  const Mat3& r = image.camera.rotation;
  for (int i = 0; i < 3; ++i) image.camera.center[i] = -(r[0][i] * t[0] + r[1][i] * t[1] + r[2][i] * t[2]);
  image.name = line.fields[9];
  try {
    check_camera(image.camera, "image " + shown(image.name));
  } catch (const ArgumentError& error) {
    throw InputError(line.file, line.place(), error.what());
  }
  return image;
}

}  // namespace

std::vector<ColmapImage> read_colmap_model(const std::string& model_dir) {
  const std::map<long long, FrameCamera> cameras = read_cameras_txt(model_dir);
  std::ifstream in = open_model_file(model_dir, "images.txt");
  const std::string path = (std::filesystem::path(model_dir) / "images.txt").string();
  std::vector<ColmapImage> images;
  std::set<long long> ids;
  std::set<std::string> names;
  std::string text;
  for (int number = 1; std::getline(in, text); ++number) {
    if (is_comment(text)) continue;
    const ModelLine line{path, number, split_fields(text)};
    if (line.fields.size() != 10)
      throw InputError(
          path, line.place(),
          "needs IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME (10 fields), got " + std::to_string(line.fields.size()));
    ColmapImage image = parse_image(line, cameras);
    if (!ids.insert(image.id).second || !names.insert(image.name).second)
      throw InputError(path, line.place(),
                       "image " + shown(image.name) + " (IMAGE_ID " + std::to_string(image.id) + ") given twice");
    images.push_back(std::move(image));
    const int image_line = number;
    // Its 2D points, not read: X Y POINT3D_ID triples, or an empty line. COLMAP's reader takes
    // this line whatever it holds; a model written without these lines would be read as every
    // other image, the next image's line (10 fields) taken for points, so the count is checked.
    if (std::getline(in, text)) {
      ++number;
      if (const std::size_t fields = split_fields(text).size(); fields % 3 != 0)
        throw InputError(path, "line " + std::to_string(number),
                         "expected the 2D points of image " + shown(images.back().name) + " (line " +
                             std::to_string(image_line) + "): X Y POINT3D_ID triples or an empty line, got " +
                             std::to_string(fields) + " fields (images.txt has two lines per image)");
    }
  }
  if (images.size() < 2)
    throw InputError(path, "", "holds " + std::to_string(images.size()) + " image(s); stereo needs at least two");
  return images;
}

}  // namespace dsmplan
