#include "runtime/snapshot.hpp"

#include <fmt/format.h>
#include <hdf5.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <vector>

#include "runtime/checkpoint.hpp"
#include "runtime/provenance.hpp"

namespace hardrod {

namespace {

void check(herr_t status, const std::string &what, const std::string &path) {
  if (status < 0) throw std::runtime_error(fmt::format("{}: HDF5 error while {}", path, what));
}

hid_t make_group(hid_t parent, const char *name) {
  return H5Gcreate2(parent, name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
}

void write_attribute(hid_t obj, const char *name, hid_t type, const void *data, hsize_t count) {
  const hid_t space = count == 1 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &count, nullptr);
  const hid_t attr = H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
  H5Awrite(attr, type, data);
  H5Aclose(attr);
  H5Sclose(space);
}

// A variable-length ASCII string, as H5MD asks for its string attributes (and h5py reads as
// str rather than bytes).
void write_string_attribute(hid_t obj, const char *name, const std::string &value) {
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, H5T_VARIABLE);
  const char *data = value.c_str();
  write_attribute(obj, name, type, &data, 1);
  H5Tclose(type);
}

// An extensible dataset of shape [0, tail...] with unlimited first dimension.
void make_series(hid_t group, const char *name, hid_t type, std::vector<hsize_t> tail) {
  std::vector<hsize_t> dims{0}, maxdims{H5S_UNLIMITED}, chunk{1};
  for (hsize_t t : tail) {
    dims.push_back(t);
    maxdims.push_back(t);
    chunk.push_back(t);
  }
  const hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), maxdims.data());
  const hid_t props = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(props, static_cast<int>(chunk.size()), chunk.data());
  const hid_t set = H5Dcreate2(group, name, type, space, H5P_DEFAULT, props, H5P_DEFAULT);
  H5Dclose(set);
  H5Pclose(props);
  H5Sclose(space);
}

// Appends one frame (row `frame`) to the dataset at `path`.
void append_row(hid_t file, const std::string &path, hid_t type, const void *data, long long frame,
                const std::string &file_name) {
  const hid_t set = H5Dopen2(file, path.c_str(), H5P_DEFAULT);
  if (set < 0) throw std::runtime_error(fmt::format("{}: missing dataset {}", file_name, path));
  hid_t space = H5Dget_space(set);
  const int rank = H5Sget_simple_extent_ndims(space);
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  H5Sclose(space);
  dims[0] = static_cast<hsize_t>(frame) + 1;
  check(H5Dset_extent(set, dims.data()), "extending " + path, file_name);
  space = H5Dget_space(set);
  std::vector<hsize_t> start(dims.size(), 0), count = dims;
  start[0] = static_cast<hsize_t>(frame);
  count[0] = 1;
  H5Sselect_hyperslab(space, H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr);
  const hid_t memory = H5Screate_simple(rank, count.data(), nullptr);
  check(H5Dwrite(set, type, memory, space, H5P_DEFAULT, data), "writing " + path, file_name);
  H5Sclose(memory);
  H5Sclose(space);
  H5Dclose(set);
}

// Shape of a dataset, or an error naming it.
std::vector<hsize_t> dataset_shape(hid_t file, const std::string &name, const std::string &path) {
  // Each group on the way must exist, or H5Lexists fails rather than saying no.
  for (std::size_t at = name.find('/', 1); at != std::string::npos; at = name.find('/', at + 1))
    if (H5Lexists(file, name.substr(0, at).c_str(), H5P_DEFAULT) <= 0)
      throw std::runtime_error(fmt::format("{}: {} is missing", path, name.substr(0, at)));
  if (H5Lexists(file, name.c_str(), H5P_DEFAULT) <= 0)
    throw std::runtime_error(fmt::format("{}: dataset {} is missing", path, name));
  const hid_t set = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
  const hid_t space = H5Dget_space(set);
  const int rank = H5Sget_simple_extent_ndims(space);
  std::vector<hsize_t> dims(static_cast<std::size_t>(std::max(rank, 0)));
  if (rank > 0) H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  H5Sclose(space);
  H5Dclose(set);
  return dims;
}

// Reads `count` rows from row `start` of dataset `name` (first dimension) as `type`.
template <typename T>
std::vector<T> read_rows(hid_t file, const std::string &name, hid_t type,
                         const std::vector<hsize_t> &dims, hsize_t start, const std::string &path) {
  const hid_t set = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
  const hid_t space = H5Dget_space(set);
  std::vector<hsize_t> offset(dims.size(), 0), count = dims;
  offset[0] = start;
  count[0] = 1;
  H5Sselect_hyperslab(space, H5S_SELECT_SET, offset.data(), nullptr, count.data(), nullptr);
  hsize_t total = 1;
  for (std::size_t k = 1; k < dims.size(); ++k) total *= dims[k];
  const hid_t memory = H5Screate_simple(1, &total, nullptr);
  std::vector<T> out(total);
  const herr_t status = H5Dread(set, type, memory, space, H5P_DEFAULT, out.data());
  H5Sclose(memory);
  H5Sclose(space);
  H5Dclose(set);
  if (status < 0) throw std::runtime_error(fmt::format("{}: cannot read {}", path, name));
  return out;
}

// All of a 1D dataset of `count` values.
template <typename T>
std::vector<T> read_all(hid_t file, const std::string &name, hid_t type, hsize_t count,
                        const std::string &path) {
  const hid_t set = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
  std::vector<T> out(count);
  const herr_t status = H5Dread(set, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data());
  H5Dclose(set);
  if (status < 0) throw std::runtime_error(fmt::format("{}: cannot read {}", path, name));
  return out;
}

const char *const kUnitSystem =
    "reduced: length D (rod diameter), mass m (body mass), energy kT, time tau = D sqrt(m/kT); "
    "each value's unit is its reduced_unit attribute (docs/units.md)";

// The time-dependent elements of /particles/all and the unit of their values (H5MD unit
// strings in hardrod's reduced units, docs/units.md; the axis is a unit vector).
struct Element {
  const char *name;
  const char *unit;  // nullptr: dimensionless
};
const std::array<Element, 4> kElements = {
    {{"position", "D"}, {"velocity", "D tau-1"}, {"axis", nullptr}, {"angular_velocity", "tau-1"}}};

// Series that only files written since the box became time-dependent have: cut and appended
// when present, so that a resumed run goes on writing an older file in its own layout.
const std::array<const char *, 3> kNewerSeries = {"/particles/all/box/edges/value",
                                                  "/particles/wrapped/position/value",
                                                  "/particles/wrapped/image/value"};

// Each frame's state checksum (body_hash: FNV-1a of ids, positions, axes, velocities and
// angular velocities, in id order; the last frame's is summary.json's state_checksum), so
// that a reader can tell a damaged frame from a good one. Files from before it lack it.
constexpr const char *kChecksumSeries = "/observables/state_checksum/value";

// The unit in hardrod's reduced units, as `reduced_unit`: H5MD's `unit` attribute is for SI
// symbols, and MDAnalysis 2.4 refuses to open a file whose `unit` it does not know, even
// with convert_units=False. The unit system itself is named in /h5md/modules/units.
void set_unit(hid_t group, const char *dataset, const char *unit) {
  const hid_t set = H5Dopen2(group, dataset, H5P_DEFAULT);
  write_string_attribute(set, "reduced_unit", unit);
  H5Dclose(set);
}

bool series_exists(hid_t file, const std::string &name) {
  std::size_t at = 0;
  while ((at = name.find('/', at + 1)) != std::string::npos)
    if (H5Lexists(file, name.substr(0, at).c_str(), H5P_DEFAULT) <= 0) return false;
  return H5Lexists(file, name.c_str(), H5P_DEFAULT) > 0;
}

// The box of frame `index`: /particles/all/box/edges as a fixed [3] or [3][3] dataset, or as
// a time-dependent element with value[frames][3] or [frames][3][3]; a matrix must be
// diagonal (hardrod's boxes are rectangular).
Box read_box(hid_t file, const std::string &path, hsize_t frames, hsize_t index) {
  const std::string edges = "/particles/all/box/edges";
  const bool series = series_exists(file, edges + "/value");
  const std::string name = series ? edges + "/value" : edges;
  auto dims = dataset_shape(file, name, path);
  if (series) {
    if (dims.empty() || dims[0] != frames)
      throw std::runtime_error(
          fmt::format("{}: {} must have one row per position frame ({})", path, name, frames));
    dims.erase(dims.begin());
  }
  const bool vector = dims == std::vector<hsize_t>{3};
  if (!vector && dims != std::vector<hsize_t>{3, 3})
    throw std::runtime_error(
        fmt::format("{}: {} must hold 3 edges or a 3 x 3 matrix per frame", path, name));
  std::vector<double> v;
  if (series) {
    dims.insert(dims.begin(), frames);
    v = read_rows<double>(file, name, H5T_NATIVE_DOUBLE, dims, index, path);
  } else {
    v = read_all<double>(file, name, H5T_NATIVE_DOUBLE, vector ? 3 : 9, path);
  }
  if (!vector) {
    for (std::size_t r = 0; r < 3; ++r)
      for (std::size_t c = 0; c < 3; ++c)
        if (r != c && v[3 * r + c] != 0.0)
          throw std::runtime_error(fmt::format(
              "{}: {}: edge {} has component {} along axis {}; hardrod's boxes are rectangular",
              path, name, r, v[3 * r + c], c));
    v = {v[0], v[4], v[8]};
  }
  for (double e : v)
    if (!(std::isfinite(e) && e > 0))
      throw std::runtime_error(fmt::format("{}: box edge {}: must be > 0 and finite", path, e));
  return Box{{v[0], v[1], v[2]}};
}

// H5MD shares step and time between elements written together through hard links.
void link_step_and_time(hid_t file, const std::string &from, const std::string &to) {
  for (const char *series : {"/step", "/time"})
    H5Lcreate_hard(file, (from + series).c_str(), file, (to + series).c_str(), H5P_DEFAULT,
                   H5P_DEFAULT);
}

void write_h5md_group(hid_t file, const Provenance &provenance) {
  const hid_t h5md = make_group(file, "h5md");
  const int version[2] = {1, 1};
  write_attribute(h5md, "version", H5T_NATIVE_INT, version, 2);
  const hid_t author = make_group(h5md, "author");
  write_string_attribute(author, "name", "hardrod");
  H5Gclose(author);
  const hid_t creator = make_group(h5md, "creator");
  write_string_attribute(creator, "name", "hardrod");
  write_string_attribute(creator, "version", provenance.version);
  H5Gclose(creator);
  const hid_t modules = make_group(h5md, "modules");
  const hid_t units = make_group(modules, "units");
  const int units_version[2] = {1, 0};
  write_attribute(units, "version", H5T_NATIVE_INT, units_version, 2);
  write_string_attribute(units, "system", kUnitSystem);
  H5Gclose(units);
  H5Gclose(modules);
  H5Gclose(h5md);
}

// The periodic box as a time-dependent element: value[T][3][3], the edge vectors as rows (a
// diagonal matrix), which is the form MDAnalysis reads; step and time are position's.
void make_box(hid_t file, hid_t all) {
  const hid_t box = make_group(all, "box");
  const int dimension = 3;
  write_attribute(box, "dimension", H5T_NATIVE_INT, &dimension, 1);
  const hid_t strtype = H5Tcopy(H5T_C_S1);
  H5Tset_size(strtype, 9);
  const char boundary[3][9] = {"periodic", "periodic", "periodic"};
  write_attribute(box, "boundary", strtype, boundary, 3);
  H5Tclose(strtype);
  const hid_t edges = make_group(box, "edges");
  make_series(edges, "value", H5T_NATIVE_DOUBLE, {3, 3});
  set_unit(edges, "value", "D");
  H5Gclose(edges);
  H5Gclose(box);
  link_step_and_time(file, "/particles/all/position", "/particles/all/box/edges");
}

void write_ids(hid_t all, long long count) {
  const hid_t ids = make_group(all, "id");
  const hsize_t n = static_cast<hsize_t>(count);
  const hid_t idspace = H5Screate_simple(1, &n, nullptr);
  const hid_t idset =
      H5Dcreate2(ids, "value", H5T_NATIVE_LLONG, idspace, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  std::vector<long long> id(static_cast<std::size_t>(count));
  for (std::size_t k = 0; k < id.size(); ++k) id[k] = static_cast<long long>(k);
  H5Dwrite(idset, H5T_NATIVE_LLONG, H5S_ALL, H5S_ALL, H5P_DEFAULT, id.data());
  H5Dclose(idset);
  H5Sclose(idspace);
  H5Gclose(ids);
}

// /particles/wrapped: the same bodies with positions folded into [0, l) and the H5MD image
// counts, so that position + image * edges gives /particles/all/position (to round-off).
// The box and every step and time are /particles/all's, through hard links.
void make_wrapped(hid_t file, hid_t particles, long long n) {
  const hid_t wrapped = make_group(particles, "wrapped");
  const std::vector<hsize_t> shape{static_cast<hsize_t>(n), 3};
  const hid_t position = make_group(wrapped, "position");
  make_series(position, "value", H5T_NATIVE_DOUBLE, shape);
  set_unit(position, "value", "D");
  H5Gclose(position);
  const hid_t image = make_group(wrapped, "image");
  make_series(image, "value", H5T_NATIVE_INT, shape);
  H5Gclose(image);
  H5Gclose(wrapped);
  H5Lcreate_hard(file, "/particles/all/box", file, "/particles/wrapped/box", H5P_DEFAULT,
                 H5P_DEFAULT);
  link_step_and_time(file, "/particles/all/position", "/particles/wrapped/position");
  link_step_and_time(file, "/particles/all/position", "/particles/wrapped/image");
}

// /observables/state_checksum: one unsigned 64-bit checksum per frame (kChecksumSeries);
// step and time are position's.
void make_checksums(hid_t file) {
  const hid_t observables = make_group(file, "observables");
  const hid_t checksum = make_group(observables, "state_checksum");
  make_series(checksum, "value", H5T_NATIVE_UINT64, {});
  write_string_attribute(checksum, "description",
                         "FNV-1a 64 of each frame's ids, positions, axes, velocities and angular "
                         "velocities in id order (hardrod's state_checksum)");
  H5Gclose(checksum);
  H5Gclose(observables);
  link_step_and_time(file, "/particles/all/position", "/observables/state_checksum");
}

// The scene's shape and the provenance (the same keys as summary.json).
void write_parameters(hid_t file, const Scene &scene, const Provenance &provenance) {
  const hid_t parameters = make_group(file, "parameters");
  write_attribute(parameters, "aspect_ratio", H5T_NATIVE_DOUBLE, &scene.shape.length, 1);
  write_attribute(parameters, "diameter", H5T_NATIVE_DOUBLE, &scene.shape.diameter, 1);
  write_attribute(parameters, "n", H5T_NATIVE_LLONG, &scene.n, 1);
  write_string_attribute(parameters, "shape", scene.shape_name);
  const nlohmann::json keys = provenance_json(provenance);
  for (const auto &[key, value] : keys.items())
    write_string_attribute(parameters, key.c_str(), value.get<std::string>());
  H5Gclose(parameters);
}

// The file opened for reading, or why not (missing, unreadable, not HDF5).
hid_t open_h5md(const std::string &path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  if (H5Fis_hdf5(path.c_str()) <= 0) {
    const int missing = access(path.c_str(), R_OK) != 0 ? errno : 0;  // say why, if the OS can
    throw std::runtime_error(fmt::format(
        "{}: {}", path,
        missing ? std::strerror(missing) : "not an HDF5 file (damaged or another format)"));
  }
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (file < 0) throw std::runtime_error(fmt::format("{}: cannot open", path));
  return file;
}

// The datasets of the bodies' positions and axes ([frames][n][3]).
constexpr const char *kPositionValue = "/particles/all/position/value";
constexpr const char *kAxisValue = "/particles/all/axis/value";

// Frame `index`'s positions and axes (rows of shape dims) into p, checked: finite, unit axes.
void read_bodies(hid_t file, const std::string &path, const std::vector<hsize_t> &dims,
                 long long index, Particles &p) {
  const auto n = static_cast<std::size_t>(dims[1]);
  const auto row = static_cast<hsize_t>(index);
  const auto x = read_rows<double>(file, kPositionValue, H5T_NATIVE_DOUBLE, dims, row, path);
  const auto e = read_rows<double>(file, kAxisValue, H5T_NATIVE_DOUBLE, dims, row, path);
  p.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    p.id[i] = static_cast<std::int64_t>(i);
    for (std::size_t a = 0; a < 3; ++a) {
      if (!std::isfinite(x[3 * i + a]) || !std::isfinite(e[3 * i + a]))
        throw std::runtime_error(
            fmt::format("{}: frame {}, body {}: position or axis not finite", path, index, i));
    }
    p.set_position(i, {x[3 * i], x[3 * i + 1], x[3 * i + 2]});
    p.set_axis(i, {e[3 * i], e[3 * i + 1], e[3 * i + 2]});
    const double length = norm(p.axis(i));
    if (std::fabs(length - 1.0) > 1e-6)
      throw std::runtime_error(
          fmt::format("{}: frame {}, body {}: axis has length {}, must be a unit vector", path,
                      index, i, length));
  }
}

// Where the file lists ids (/particles/all/id/value, one per body), they must be 0..n-1.
void check_id_order(hid_t file, const std::string &path, hsize_t n) {
  if (H5Lexists(file, "/particles/all/id", H5P_DEFAULT) <= 0 ||
      H5Lexists(file, "/particles/all/id/value", H5P_DEFAULT) <= 0)
    return;
  if (dataset_shape(file, "/particles/all/id/value", path) != std::vector<hsize_t>{n}) return;
  const auto ids = read_all<long long>(file, "/particles/all/id/value", H5T_NATIVE_LLONG, n, path);
  for (std::size_t i = 0; i < ids.size(); ++i)
    if (ids[i] != static_cast<long long>(i))
      throw std::runtime_error(
          fmt::format("{}: /particles/all/id/value[{}] = {}: bodies must be in id order 0..n-1",
                      path, i, ids[i]));
}

}  // namespace

SnapshotFrame read_h5md_frame(const std::string &path, long long frame) {
  const hid_t file = open_h5md(path);
  struct Closer {
    hid_t f;
    ~Closer() { H5Fclose(f); }
  } closer{file};
  const std::string position = kPositionValue, axis = kAxisValue;
  const auto dims = dataset_shape(file, position, path);
  if (dims.size() != 3 || dims[2] != 3 || dims[1] == 0)
    throw std::runtime_error(fmt::format("{}: {} must have shape [frames][n][3]", path, position));
  const auto frames = static_cast<long long>(dims[0]);
  const long long index = frame < 0 ? frames + frame : frame;
  if (index < 0 || index >= frames)
    throw std::runtime_error(
        fmt::format("{}: frame {} requested, the file has {} frame(s)", path, frame, frames));
  if (dataset_shape(file, axis, path) != dims)
    throw std::runtime_error(fmt::format("{}: {} and {} differ in shape", path, position, axis));
  SnapshotFrame out;
  out.frame = index;
  out.frames = frames;
  out.box = read_box(file, path, dims[0], static_cast<hsize_t>(index));
  if (H5Lexists(file, "/particles/all/position/step", H5P_DEFAULT) > 0) {
    const auto steps = dataset_shape(file, "/particles/all/position/step", path);
    if (steps.size() == 1 && steps[0] == dims[0])
      out.step = read_all<long long>(file, "/particles/all/position/step", H5T_NATIVE_LLONG,
                                     dims[0], path)[static_cast<std::size_t>(index)];
  }
  read_bodies(file, path, dims, index, out.bodies);
  check_id_order(file, path, dims[1]);
  return out;
}

std::optional<std::uint64_t> read_frame_checksum(const std::string &path, long long frame) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (file < 0) throw std::runtime_error(fmt::format("{}: cannot open", path));
  std::optional<std::uint64_t> out;
  try {
    if (series_exists(file, kChecksumSeries)) {
      const std::vector<hsize_t> dims = dataset_shape(file, kChecksumSeries, path);
      if (dims.size() != 1 || frame < 0 || static_cast<hsize_t>(frame) >= dims[0])
        throw std::runtime_error(
            fmt::format("{}: {} has no frame {}", path, kChecksumSeries, frame));
      out = read_rows<std::uint64_t>(file, kChecksumSeries, H5T_NATIVE_UINT64, dims,
                                     static_cast<hsize_t>(frame), path)[0];
    }
  } catch (...) {
    H5Fclose(file);
    throw;
  }
  H5Fclose(file);
  return out;
}

void keep_hdf5_out_of_exit() { H5dont_atexit(); }

TrajectoryWriter::TrajectoryWriter(const std::string &path, const Scene &scene)
    : n_(scene.n),
      edges_{scene.box.length.x, scene.box.length.y, scene.box.length.z},
      box_series_(true),
      wrapped_(true),
      checksums_(true),
      path_(path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // our messages, not HDF5's error stack
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (file < 0) throw std::runtime_error(fmt::format("{}: cannot create the H5MD file", path));
  file_ = file;
  const Provenance &provenance = process_provenance();
  write_h5md_group(file, provenance);
  const hid_t particles = make_group(file, "particles");
  const hid_t all = make_group(particles, "all");
  for (const auto &element : kElements) {
    const hid_t g = make_group(all, element.name);
    make_series(g, "step", H5T_NATIVE_LLONG, {});
    make_series(g, "time", H5T_NATIVE_DOUBLE, {});
    make_series(g, "value", H5T_NATIVE_DOUBLE,
                {static_cast<hsize_t>(scene.n), static_cast<hsize_t>(3)});
    if (element.unit) set_unit(g, "value", element.unit);
    set_unit(g, "time", "tau");
    H5Gclose(g);
  }
  make_box(file, all);
  write_ids(all, scene.n);
  H5Gclose(all);
  make_wrapped(file, particles, scene.n);
  H5Gclose(particles);
  make_checksums(file);
  write_parameters(file, scene, provenance);
  close_file("creating the file");
}

TrajectoryWriter::TrajectoryWriter(const std::string &path, const Scene &scene,
                                   long long keep_frames)
    : n_(scene.n),
      frames_(keep_frames),
      edges_{scene.box.length.x, scene.box.length.y, scene.box.length.z},
      path_(path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  if (file < 0) throw std::runtime_error(fmt::format("{}: cannot reopen the H5MD file", path));
  file_ = file;
  try {
    cut_back(scene.n, keep_frames);
  } catch (...) {
    H5Fclose(file);  // the destructor does not run for a constructor that throws
    throw;
  }
  close_file("cutting it back to the checkpoint's frames");
}

namespace {

// Cuts the series `name` (frames first) back to `keep_frames` rows; throws naming the file,
// the dataset and the problem.
void cut_series(hid_t file, const std::string &name, long long n, long long keep_frames,
                const std::string &path, bool per_body = true) {
  const hid_t set = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
  const hid_t space = H5Dget_space(set);
  const int rank = H5Sget_simple_extent_ndims(space);
  std::vector<hsize_t> dims(static_cast<std::size_t>(std::max(rank, 1)), 0);
  H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  H5Sclose(space);
  std::string problem;
  if (static_cast<long long>(dims[0]) < keep_frames)
    problem =
        fmt::format("{} has {} frames, the checkpoint recorded {}", name, dims[0], keep_frames);
  else if (per_body && rank == 3 && static_cast<long long>(dims[1]) != n)
    problem = fmt::format("{} holds {} bodies, the scene {}", name, dims[1], n);
  dims[0] = static_cast<hsize_t>(keep_frames);
  if (problem.empty() && H5Dset_extent(set, dims.data()) < 0)
    problem = fmt::format("cannot cut {} back to {} frames", name, keep_frames);
  H5Dclose(set);
  if (!problem.empty()) throw std::runtime_error(fmt::format("{}: {}", path, problem));
}

}  // namespace

void TrajectoryWriter::cut_back(long long n, long long keep_frames) {
  const hid_t file = static_cast<hid_t>(file_);
  for (const auto &element : kElements) {
    for (const char *series : {"step", "time", "value"}) {
      const std::string name = fmt::format("/particles/all/{}/{}", element.name, series);
      if (!series_exists(file, name))
        throw std::runtime_error(fmt::format("{}: dataset {} is missing", path_, name));
      cut_series(file, name, n, keep_frames, path_);
    }
  }
  // A file from before the time-dependent box goes on in its own layout.
  box_series_ = series_exists(file, kNewerSeries[0]);
  wrapped_ = series_exists(file, kNewerSeries[1]) && series_exists(file, kNewerSeries[2]);
  if (box_series_) cut_series(file, kNewerSeries[0], n, keep_frames, path_, false);
  if (wrapped_)
    for (const char *name : {kNewerSeries[1], kNewerSeries[2]})
      cut_series(file, name, n, keep_frames, path_);
  checksums_ = series_exists(file, kChecksumSeries);
  if (checksums_) cut_series(file, kChecksumSeries, n, keep_frames, path_, false);
}

TrajectoryWriter::~TrajectoryWriter() {
  if (file_ >= 0) H5Fclose(static_cast<hid_t>(file_));  // a frame that threw
}

void TrajectoryWriter::close_file(const std::string &what) {
  const auto file = static_cast<hid_t>(file_);
  file_ = -1;
  check(H5Fclose(file), what, path_);
}

void TrajectoryWriter::append(const Particles &bodies, long long step, double time) {
  if (static_cast<long long>(bodies.size()) != n_)
    throw std::runtime_error(
        fmt::format("{}: frame has {} bodies, the file {}", path_, bodies.size(), n_));
  const hid_t file = H5Fopen(path_.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  if (file < 0) throw std::runtime_error(fmt::format("{}: cannot reopen the H5MD file", path_));
  file_ = file;
  std::vector<double> buffer(static_cast<std::size_t>(n_) * 3);
  const std::array<std::array<const std::vector<double> *, 3>, 4> fields = {{
      {&bodies.x, &bodies.y, &bodies.z},
      {&bodies.vx, &bodies.vy, &bodies.vz},
      {&bodies.ex, &bodies.ey, &bodies.ez},
      {&bodies.wx, &bodies.wy, &bodies.wz},
  }};
  for (std::size_t e = 0; e < kElements.size(); ++e) {
    const std::string base = std::string("/particles/all/") + kElements[e].name;
    for (std::size_t i = 0; i < static_cast<std::size_t>(n_); ++i)
      for (std::size_t a = 0; a < 3; ++a) buffer[3 * i + a] = (*fields[e][a])[i];
    append_row(file, base + "/value", H5T_NATIVE_DOUBLE, buffer.data(), frames_, path_);
    append_row(file, base + "/step", H5T_NATIVE_LLONG, &step, frames_, path_);
    append_row(file, base + "/time", H5T_NATIVE_DOUBLE, &time, frames_, path_);
  }
  if (box_series_) {  // step and time are position's (hard links)
    const double matrix[9] = {edges_[0], 0, 0, 0, edges_[1], 0, 0, 0, edges_[2]};
    append_row(file, kNewerSeries[0], H5T_NATIVE_DOUBLE, matrix, frames_, path_);
  }
  if (wrapped_) {
    std::vector<int> image(buffer.size());
    for (std::size_t i = 0; i < static_cast<std::size_t>(n_); ++i) {
      const std::array<double, 3> x = {bodies.x[i], bodies.y[i], bodies.z[i]};
      for (std::size_t a = 0; a < 3; ++a) {
        buffer[3 * i + a] = Box::wrap(x[a], edges_[a]);
        image[3 * i + a] = static_cast<int>(std::lround((x[a] - buffer[3 * i + a]) / edges_[a]));
      }
    }
    append_row(file, kNewerSeries[1], H5T_NATIVE_DOUBLE, buffer.data(), frames_, path_);
    append_row(file, kNewerSeries[2], H5T_NATIVE_INT, image.data(), frames_, path_);
  }
  if (checksums_) {
    const std::uint64_t hash = body_hash(bodies);
    append_row(file, kChecksumSeries, H5T_NATIVE_UINT64, &hash, frames_, path_);
  }
  // A killed run keeps every complete frame; a full disk shows here at the latest.
  close_file("writing frame " + std::to_string(frames_));
  ++frames_;
}

}  // namespace hardrod
