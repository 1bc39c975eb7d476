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
// Pairs of points, model frame and CRS, each with its label (the image, or the GCP's name) and line.
struct MatchedCentres {
  std::vector<Vec3> model, crs;
  std::vector<std::string> labels;
  std::vector<std::string> files, places;  // where each was given, for the refusal
  const char* what = "centres";
};

// The model's images by NAME, else by the NAME's file name when unique.
class ImageIndex {
public:
  explicit ImageIndex(const std::vector<ColmapImage>& images) {
    for (int i = 0; i < static_cast<int>(images.size()); ++i) {
      by_name_[images[i].name] = i;
      const std::string file = std::filesystem::path(images[i].name).filename().string();
      by_file_[file] = by_file_.count(file) ? -1 : i;  // -1: two images share the file name
    }
  }
  int find(const std::string& image) const {  // -1 when not in the model
    if (const auto named = by_name_.find(image); named != by_name_.end()) return named->second;
    if (const auto file = by_file_.find(std::filesystem::path(image).filename().string()); file != by_file_.end())
      return file->second;
    return -1;
  }

private:
  std::map<std::string, int> by_name_, by_file_;
};

MatchedCentres match_centres(const std::string& path, const std::vector<ColmapImage>& images,
                             const std::vector<CentreRow>& rows) {
  const ImageIndex index(images);
  MatchedCentres out;
  for (const CentreRow& row : rows) {
    const int i = index.find(row.image);
    if (i < 0) continue;
    out.model.push_back(images[i].camera.center);
    out.crs.push_back(row.position);
    out.labels.push_back(row.image);
    out.files.push_back(path);
    out.places.push_back("line " + std::to_string(row.line));
  }
  return out;
}

// Each ground control point triangulated in the model's frame from its observations in the
// model's images, refused in one line when it cannot be.
MatchedCentres triangulate_gcps(const std::string& path, const std::vector<ColmapImage>& images,
                                const std::vector<GcpPoint>& points, double& reprojection_max) {
  const ImageIndex index(images);
  MatchedCentres out;
  out.what = "ground control points";
  for (const GcpPoint& point : points) {
    std::vector<FrameCamera> cameras;
    std::vector<std::array<double, 2>> pixels;
    std::vector<const GcpObservation*> used;
    std::string missing;
    for (const GcpObservation& o : point.observations) {
      const int i = index.find(o.image);
      if (i < 0) {
        if (missing.empty()) missing = o.image;
        continue;
      }
      cameras.push_back(images[i].camera);
      pixels.push_back({o.u, o.v});
      used.push_back(&o);
    }
    const std::string label = "point " + shown(point.name);
    const std::string place = "line " + std::to_string(point.line);
    if (cameras.size() < 2)
      throw InputError(
          path, place,
          label + " is seen in " + std::to_string(cameras.size()) +
              " image(s) of the model; 2 are needed to triangulate it" +
              (missing.empty() ? std::string() : " (" + shown(missing) + " is not a registered image of the model)"));
    const ViewTriangulation t = triangulate_views(cameras, pixels);
    if (!t.finite || !(t.ray_angle >= kMinGcpRayAngle))
      throw InputError(path, place,
                       label + "'s rays meet at " + two_decimals(t.ray_angle * 180 / 3.14159265358979323846) +
                           " degrees (under 0.2): its position along them is not determined; give it in images "
                           "further apart");
    if (t.behind >= 0)
      throw InputError(path, "line " + std::to_string(used[t.behind]->line),
                       label + " triangulates behind the camera of image " + shown(used[t.behind]->image) +
                           ": a wrong pixel position or image");
    if (!(t.max_reprojection <= kMaxGcpReprojection))
      throw InputError(path, "line " + std::to_string(used[t.worst]->line),
                       label + "'s observations disagree: its triangulation lies " + two_decimals(t.max_reprojection) +
                           " px from its pixel in " + shown(used[t.worst]->image) +
                           " (over 10 px): a wrong pixel position or image");
    reprojection_max = std::max(reprojection_max, t.max_reprojection);
    out.model.push_back(t.point);
    out.crs.push_back(point.position);
    out.labels.push_back(point.name);
    out.files.push_back(path);
    out.places.push_back(place);
  }
  return out;
}

// Positions in longitude and latitude where the CRS is metric (a geographic --crs is refused by
// the job): every one within +-180, +-90 and all within a metre of each other horizontally, which
// no flight's centres or control points are. Fitted, they would make a DSM of a cell or two.
void refuse_degrees(const std::string& path, const MatchedCentres& matched, const std::string& crs) {
  double x0 = matched.crs[0][0], x1 = x0, y0 = matched.crs[0][1], y1 = y0;
  for (const Vec3& p : matched.crs) {
    if (!(std::abs(p[0]) <= 180 && std::abs(p[1]) <= 90)) return;
    x0 = std::min(x0, p[0]), x1 = std::max(x1, p[0]), y0 = std::min(y0, p[1]), y1 = std::max(y1, p[1]);
  }
  if (std::hypot(x1 - x0, y1 - y0) >= 1) return;
  throw InputError(path, "",
                   "the " + std::string(matched.what) + " lie within " + short_number(std::hypot(x1 - x0, y1 - y0)) +
                       " of each other in x and y and within +-180, +-90: longitude and latitude in degrees? "
                       "give x, y in " +
                       crs + "'s metres (e.g. with `cs2cs EPSG:4326 " + crs + "`), or --centres exif");
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
void measure_residuals(const MatchedCentres& matched, const Similarity& transform, Georeference& out) {
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
  out.rms = std::sqrt(sum / static_cast<double>(matched.crs.size()));
  out.worst = matched.labels[worst];
  out.bound = std::max(kMinFitBound, kFitBoundShare * extent);
  if (!(out.rms <= out.bound))
    throw InputError(matched.files[worst], matched.places[worst],
                     "the similarity leaves residuals of RMS " + two_decimals(out.rms) + " m (max " +
                         two_decimals(out.max) + " m, at " + (std::string(matched.what) == "centres" ? "" : "point ") +
                         shown(out.worst) + "), over the bound " + two_decimals(out.bound) +
                         " m = max(0.5 m, 1 % of the " + matched.what + "' extent " + two_decimals(extent) +
                         " m): a wrong " +
                         (std::string(matched.what) == "centres" ? "centre" : "point or pixel position") +
                         ", or a model of other images");
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
                         std::string(1, "xyz"[k]) + " must be a finite number, got " + shown(fields[1 + k]));
    row.image = fields[0];
    row.line = number;
    if (const auto [it, fresh] = seen.emplace(row.image, number); !fresh)
      throw InputError(path, place,
                       "image " + shown(row.image) + " given twice (also line " + std::to_string(it->second) + ")");
    rows.push_back(row);
  }
  return rows;
}

std::vector<GcpPoint> read_gcps(const std::string& path) {
  require_input_file(path, std::uint64_t{256} << 20, "a --gcps CSV");
  std::ifstream in(path);
  if (!in) throw InputError(path, "", "missing or cannot be opened");
  std::vector<GcpPoint> points;
  std::map<std::string, std::size_t> by_name;
  std::vector<std::string> header;
  int x = -1, y = -1, z = -1, image = -1, u = -1, v = -1, name = -1;
  std::string text;
  for (int number = 1; std::getline(in, text); ++number) {
    if (trimmed(text).empty() || trimmed(text)[0] == '#') continue;
    std::vector<std::string> fields;
    std::istringstream line(text);
    for (std::string field; std::getline(line, field, ',');) fields.push_back(trimmed(field));
    if (!text.empty() && text.back() == ',') fields.push_back("");
    const std::string place = "line " + std::to_string(number);
    if (header.empty()) {
      header = fields;
      for (int i = 0; i < static_cast<int>(fields.size()); ++i) {
        const std::string column = lower_case(fields[i]);
        for (auto [key, index] :
             {std::pair{"x", &x}, std::pair{"y", &y}, std::pair{"z", &z}, std::pair{"image", &image},
              std::pair{"u", &u}, std::pair{"v", &v}, std::pair{"point", &name}})
          if (column == key) *index = i;
      }
      for (auto [key, index] : {std::pair{"x", x}, std::pair{"y", y}, std::pair{"z", z}, std::pair{"image", image},
                                std::pair{"u", u}, std::pair{"v", v}})
        if (index < 0)
          throw InputError(path, place,
                           std::string("the header has no column ") + key +
                               "; a GCP file's header names x,y,z,image,u,v (and optionally point)");
      continue;
    }
    if (fields.size() != header.size())
      throw InputError(path, place,
                       "has " + std::to_string(fields.size()) + " fields, the header " + std::to_string(header.size()));
    const auto real = [&](int column) {
      double value = 0;
      if (!parse_real(fields[column], value))
        throw InputError(path, place, header[column] + " must be a finite number, got " + shown(fields[column]));
      return value;
    };
    const Vec3 position{real(x), real(y), real(z)};
    const GcpObservation observation{fields[image], real(u), real(v), number};
    if (observation.image.empty()) throw InputError(path, place, "the image is empty");
    const std::string key = name >= 0 ? fields[name] : fields[x] + "," + fields[y] + "," + fields[z];
    if (name >= 0 && key.empty()) throw InputError(path, place, "the point's name is empty");
    auto [it, fresh] = by_name.emplace(key, points.size());
    if (fresh) {
      points.push_back({key, position, {}, number});
    } else {
      GcpPoint& point = points[it->second];
      if (point.position != position)
        throw InputError(path, place,
                         "point " + shown(key) + " is given other x, y, z than on line " + std::to_string(point.line));
      for (const GcpObservation& o : point.observations)
        if (o.image == observation.image)
          throw InputError(path, place,
                           "point " + shown(key) + " is given twice in image " + shown(o.image) + " (also line " +
                               std::to_string(o.line) + ")");
    }
    points[it->second].observations.push_back(observation);
  }
  if (points.empty())
    throw InputError(path, "", "holds no ground control points (a header, then x,y,z,image,u,v rows)");
  return points;
}

void check(const ColmapOptions& options) {
  if (options.model.empty()) throw ArgumentError("--colmap", "needs the folder of a COLMAP text model");
  if (options.crs.empty())
    throw ArgumentError("--crs", "is needed with --colmap: the CRS of the centres (or the transform) and of the DSM");
  if (options.centres.empty() && options.transform.empty() && options.gcps.empty())
    throw ArgumentError("--centres",
                        "a COLMAP model's frame is arbitrary: give the cameras' centres in the CRS (--centres "
                        "CSV of image,x,y,z), ground control points (--gcps CSV of x,y,z,image,u,v) or the "
                        "transform into it (--transform FILE)");
  if (!options.centres.empty() && !options.gcps.empty())
    throw ArgumentError("--gcps", "give --centres or --gcps, not both: the similarity is fitted to one of them");
}

namespace {

// The model's images as files: a NAME relative to the images' folder (--images, else
// default_images_folder()), an absolute one as it is.
std::vector<std::string> image_files(const std::vector<ColmapImage>& images, const std::filesystem::path& folder) {
  std::vector<std::string> files;
  for (const ColmapImage& image : images) {
    const std::filesystem::path name = image.name;
    files.push_back((name.is_relative() ? folder / name : name).string());
  }
  return files;
}

std::filesystem::path images_folder(const ColmapOptions& options) {
  return options.images.empty() ? default_images_folder(options.model) : options.images;
}

}  // namespace

std::vector<std::string> colmap_image_paths(const ColmapOptions& options) {
  check(options);
  return image_files(read_colmap_model(options.model), images_folder(options));
}

ColmapCameras colmap_cameras(const ColmapOptions& options, const ExifCentres& exif) {
  check(options);
  const std::vector<ColmapImage> images = read_colmap_model(options.model);
  ColmapCameras out;
  CameraFile& file = out.file;
  file.path = (std::filesystem::path(options.model) / "images.txt").string();
  file.crs = options.crs;
  const std::filesystem::path folder = images_folder(options);
  file.images = image_files(images, folder);
  Similarity transform;
  if (!options.transform.empty()) {
    transform = read_similarity(options.transform);
    out.georeference.method = "transform";
  }
  if (!options.centres.empty() || !options.gcps.empty()) {
    const bool gcps = !options.gcps.empty(), from_exif = options.centres == kExifCentres;
    const std::string& path = gcps ? options.gcps : options.centres;
    MatchedCentres matched;
    if (gcps) {
      matched = triangulate_gcps(path, images, read_gcps(path), out.georeference.gcp_reprojection_max);
      if (matched.crs.size() < 3)
        throw InputError(
            path, "",
            "holds " + std::to_string(matched.crs.size()) + " ground control point(s); 3 are needed for a similarity");
      out.georeference.gcps = matched.crs.size();
    } else if (from_exif) {
      if (!exif) throw ArgumentError("--centres", "exif: this caller cannot read the images' EXIF GPS");
      const ImageCentres read = exif(file.images);
      if (read.centres.size() != images.size()) throw ArgumentError("--centres", "exif: one centre per image expected");
      for (std::size_t i = 0; i < images.size(); ++i) {
        if (!read.centres[i]) continue;
        matched.model.push_back(images[i].camera.center);
        matched.crs.push_back(*read.centres[i]);
        matched.labels.push_back(images[i].name);
        matched.files.push_back(file.images[i]);
        matched.places.push_back("EXIF GPS");
      }
      if (matched.crs.size() < 3)
        throw InputError(folder.string(), "",
                         std::to_string(matched.crs.size()) + " of the model's " + std::to_string(images.size()) +
                             " images here record a GPS position with altitude in their EXIF (3 needed for a "
                             "similarity)");
      out.georeference.centres = matched.crs.size();
      out.georeference.heights = read.heights;
    } else {
      const std::vector<CentreRow> rows = read_centres(path);
      matched = match_centres(path, images, rows);
      if (matched.crs.size() < 3)
        throw InputError(path, "",
                         std::to_string(matched.crs.size()) + " of its " + std::to_string(rows.size()) +
                             " centres name an image of the model (3 needed for a similarity; names as images.txt's "
                             "NAME, or its file name)");
      out.georeference.centres = matched.crs.size();
    }
    if (!from_exif) refuse_degrees(path, matched, options.crs);
    if (options.transform.empty()) {
      const double share = across_line_share(matched.model);
      if (!(share >= 0.01))
        throw InputError(from_exif ? folder.string() : path, "",
                         std::string("the ") + (gcps ? "ground control points" : "matched centres") +
                             " lie nearly on a line (spread across it " + two_decimals(100 * share) +
                             " % of that along it): the rotation about it is not determined; add " +
                             (gcps ? "points" : "centres") + " off the line or give --transform");
      transform = fit_similarity(matched.model, matched.crs);
      out.georeference.method = gcps ? "gcps" : from_exif ? "exif" : "centres";
    }
    out.georeference.residuals_at = gcps ? "gcps" : "centres";
    measure_residuals(matched, transform, out.georeference);
  }
  out.georeference.scale = transform.scale;
  out.transform = transform;
  for (const ColmapImage& image : images) file.cameras.push_back(transformed(image.camera, transform));
  return out;
}

}  // namespace dsmplan
