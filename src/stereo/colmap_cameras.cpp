// A COLMAP model put into a CRS (dsmplan/colmap_model.hpp): the --transform and --centres files,
// the centres matched to the model's images, the similarity fitted to them (similarity_fit.cpp,
// Umeyama 1991) and checked by its residuals, every camera carried through it, and the camera
// list the pipeline takes (CameraFile, as read_camera_file() makes from a CAMERAS.json).
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "core/text.hpp"
#include "dsmplan/colmap_model.hpp"

namespace dsmplan {

namespace {

bool parse_real(std::string text, double& value) {
  const auto first = text.find_first_not_of(" \t\r");
  const auto last = text.find_last_not_of(" \t\r");
  if (first == std::string::npos) return false;
  text = text.substr(first, last - first + 1);
  std::size_t used = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    return false;
  }
  return used == text.size() && std::isfinite(value);
}

std::string trimmed(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  return text.substr(first, text.find_last_not_of(" \t\r") - first + 1);
}

// The transform's rotation and scale from its 3 x 3 part M = s Q.
Similarity scaled_rotation(const std::string& path, const Eigen::Matrix3d& m, const Eigen::Vector3d& t) {
  const double det = m.determinant();
  if (!(det > 0)) throw InputError(path, "", "the 3 x 3 part must be a positive scale times a rotation");
  const double scale = std::cbrt(det);
  const Eigen::Matrix3d q = m / scale;
  if (!((q * q.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= 1e-6))
    throw InputError(path, "", "the 3 x 3 part is not a scale times a rotation (to 1e-6)");
  Similarity out;
  out.scale = scale;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out.rotation[i][j] = q(i, j);
    out.translation[i] = t(i);
  }
  return out;
}

// The model's images matched to the centres: by NAME, else by the NAME's file name when unique.
struct MatchedCentres {
  std::vector<Vec3> model, crs;
  std::vector<const CentreRow*> rows;
};
MatchedCentres match_centres(const std::vector<ColmapImage>& images, const std::vector<CentreRow>& rows) {
  std::map<std::string, int> by_name, by_file;
  for (int i = 0; i < static_cast<int>(images.size()); ++i) {
    by_name[images[i].name] = i;
    const std::string file = std::filesystem::path(images[i].name).filename().string();
    by_file[file] = by_file.count(file) ? -1 : i;  // -1: two images share the file name
  }
  MatchedCentres out;
  for (const CentreRow& row : rows) {
    int i = -1;
    if (const auto named = by_name.find(row.image); named != by_name.end())
      i = named->second;
    else if (const auto file = by_file.find(std::filesystem::path(row.image).filename().string());
             file != by_file.end())
      i = file->second;
    if (i < 0) continue;
    out.model.push_back(images[i].camera.center);
    out.crs.push_back(row.position);
    out.rows.push_back(&row);
  }
  return out;
}

// The spread of the points across their best line, as a share of the spread along it.
double across_line_share(const std::vector<Vec3>& points) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Vec3& p : points) mean += Eigen::Vector3d(p[0], p[1], p[2]);
  mean /= static_cast<double>(points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Vec3& p : points) {
    const Eigen::Vector3d d = Eigen::Vector3d(p[0], p[1], p[2]) - mean;
    scatter += d * d.transpose();
  }
  const Eigen::Vector3d eigen = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvalues();  // ascending
  return eigen(2) > 0 ? std::sqrt(std::max(0.0, eigen(1)) / eigen(2)) : 0.0;
}

// Residuals of `transform` at the matched centres, checked against the bound.
void measure_residuals(const std::string& path, const MatchedCentres& matched, const Similarity& transform,
                       Georeference& out) {
  Vec3 lo = matched.crs[0], hi = matched.crs[0];
  double sum = 0;
  std::size_t worst = 0;
  for (std::size_t i = 0; i < matched.crs.size(); ++i) {
    const Vec3 x = transform.apply(matched.model[i]);
    double d2 = 0;
    for (int k = 0; k < 3; ++k) {
      d2 += (x[k] - matched.crs[i][k]) * (x[k] - matched.crs[i][k]);
      lo[k] = std::min(lo[k], matched.crs[i][k]);
      hi[k] = std::max(hi[k], matched.crs[i][k]);
    }
    sum += d2;
    if (std::sqrt(d2) > out.max) out.max = std::sqrt(d2), worst = i;
  }
  const double extent = std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
  out.centres = matched.crs.size();
  out.rms = std::sqrt(sum / static_cast<double>(matched.crs.size()));
  out.worst = matched.rows[worst]->image;
  out.bound = std::max(kMinFitBound, kFitBoundShare * extent);
  if (!(out.rms <= out.bound))
    throw InputError(path, "line " + std::to_string(matched.rows[worst]->line),
                     "the similarity leaves residuals of RMS " + two_decimals(out.rms) + " m (max " +
                         two_decimals(out.max) + " m, at " + shown(out.worst) + "), over the bound " +
                         two_decimals(out.bound) + " m = max(0.5 m, 1 % of the centres' extent " +
                         two_decimals(extent) + " m): a wrong centre, or a model of other images");
}

// COLMAP's image folder as its mapper wrote it in MODEL_DIR/project.ini (`image_path=...`, the
// OptionManager's file), when that folder exists; else images/ beside the model; else the model.
std::string default_images_folder(const std::string& model) {
  std::error_code error;
  const std::string project = (std::filesystem::path(model) / "project.ini").string();
  if (std::filesystem::is_regular_file(project, error) && std::filesystem::file_size(project, error) < (1 << 20)) {
    std::ifstream in(project);
    for (std::string line; std::getline(in, line);)
      if (line.rfind("image_path=", 0) == 0) {
        const std::string folder = trimmed(line.substr(11));
        if (!folder.empty() && std::filesystem::is_directory(folder, error)) return folder;
      }
  }
  const std::filesystem::path beside = std::filesystem::path(model).parent_path() / "images";
  return std::filesystem::is_directory(beside, error) ? beside.string() : model;
}

}  // namespace

Similarity read_similarity(const std::string& path) {
  require_input_file(path, 1 << 20, "a --transform file");
  std::ifstream in(path);
  if (!in) throw InputError(path, "", "missing or cannot be opened");
  std::vector<double> numbers;
  std::string text;
  for (int number = 1; std::getline(in, text); ++number) {
    std::replace(text.begin(), text.end(), ',', ' ');
    std::istringstream fields(text.substr(0, text.find('#')));
    for (std::string field; fields >> field;) {
      double value = 0;
      if (!parse_real(field, value))
        throw InputError(path, "line " + std::to_string(number), "not a finite number: " + shown(field));
      numbers.push_back(value);
    }
  }
  Eigen::Matrix3d m;
  Eigen::Vector3d t;
  if (numbers.size() == 16 || numbers.size() == 12) {
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) m(i, j) = numbers[4 * i + j];
      t(i) = numbers[4 * i + 3];
    }
    if (numbers.size() == 16 && (numbers[12] != 0 || numbers[13] != 0 || numbers[14] != 0 || numbers[15] != 1))
      throw InputError(path, "", "the 4 x 4 matrix's last row must be 0 0 0 1");
  } else if (numbers.size() == 13) {
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) m(i, j) = numbers[0] * numbers[1 + 3 * i + j];
      t(i) = numbers[10 + i];
    }
    if (!(numbers[0] > 0)) throw InputError(path, "", "the scale (the first number) must be positive");
  } else {
    throw InputError(path, "",
                     "holds " + std::to_string(numbers.size()) +
                         " numbers; a transform is 16 (a 4 x 4 matrix by rows), 12 (its first three rows) or 13 "
                         "(scale, rotation by rows, translation)");
  }
  return scaled_rotation(path, m, t);
}

std::vector<CentreRow> read_centres(const std::string& path) {
  require_input_file(path, std::uint64_t{256} << 20, "a --centres CSV");
  std::ifstream in(path);
  if (!in) throw InputError(path, "", "missing or cannot be opened");
  std::vector<CentreRow> rows;
  std::map<std::string, int> seen;
  std::string text;
  bool first = true;
  for (int number = 1; std::getline(in, text); ++number) {
    if (trimmed(text).empty() || trimmed(text)[0] == '#') continue;
    std::vector<std::string> fields;
    std::istringstream line(text);
    for (std::string field; std::getline(line, field, ',');) fields.push_back(trimmed(field));
    const std::string place = "line " + std::to_string(number);
    CentreRow row;
    const bool header = first && fields.size() > 1 && !parse_real(fields[1], row.position[0]);
    first = false;
    if (header) continue;
    if (fields.size() != 4)
      throw InputError(path, place, "needs image,x,y,z (4 fields), got " + std::to_string(fields.size()));
    for (int k = 0; k < 3; ++k)
      if (!parse_real(fields[1 + k], row.position[k]))
        throw InputError(path, place,
                         std::string("xyz"[k], 1) + " must be a finite number, got " + shown(fields[1 + k]));
    row.image = fields[0];
    row.line = number;
    if (const auto [it, fresh] = seen.emplace(row.image, number); !fresh)
      throw InputError(path, place,
                       "image " + shown(row.image) + " given twice (also line " + std::to_string(it->second) + ")");
    rows.push_back(row);
  }
  return rows;
}

void check(const ColmapOptions& options) {
  if (options.model.empty()) throw ArgumentError("--colmap", "needs the folder of a COLMAP text model");
  if (options.crs.empty())
    throw ArgumentError("--crs", "is needed with --colmap: the CRS of the centres (or the transform) and of the DSM");
  if (options.centres.empty() && options.transform.empty())
    throw ArgumentError("--centres",
                        "a COLMAP model's frame is arbitrary: give the cameras' centres in the CRS (--centres "
                        "CSV of image,x,y,z) or the transform into it (--transform FILE)");
}

ColmapCameras colmap_cameras(const ColmapOptions& options) {
  check(options);
  const std::vector<ColmapImage> images = read_colmap_model(options.model);
  ColmapCameras out;
  Similarity transform;
  if (!options.transform.empty()) {
    transform = read_similarity(options.transform);
    out.georeference.method = "transform";
  }
  if (!options.centres.empty()) {
    const std::vector<CentreRow> rows = read_centres(options.centres);
    const MatchedCentres matched = match_centres(images, rows);
    if (matched.crs.size() < 3)
      throw InputError(options.centres, "",
                       std::to_string(matched.crs.size()) + " of its " + std::to_string(rows.size()) +
                           " centres name an image of the model (3 needed for a similarity; names as images.txt's "
                           "NAME, or its file name)");
    if (options.transform.empty()) {
      const double share = across_line_share(matched.model);
      if (!(share >= 0.01))
        throw InputError(options.centres, "",
                         "the matched centres lie nearly on a line (spread across it " + two_decimals(100 * share) +
                             " % of that along it): the rotation about it is not determined; add centres off the "
                             "line or give --transform");
      transform = fit_similarity(matched.model, matched.crs);
      out.georeference.method = "centres";
    }
    measure_residuals(options.centres, matched, transform, out.georeference);
  }
  out.georeference.scale = transform.scale;
  CameraFile& file = out.file;
  file.path = (std::filesystem::path(options.model) / "images.txt").string();
  file.crs = options.crs;
  const std::filesystem::path folder = options.images.empty() ? default_images_folder(options.model) : options.images;
  for (const ColmapImage& image : images) {
    file.cameras.push_back(transformed(image.camera, transform));
    std::filesystem::path name = image.name;
    file.images.push_back((name.is_relative() ? folder / name : name).string());
  }
  return out;
}

}  // namespace dsmplan
