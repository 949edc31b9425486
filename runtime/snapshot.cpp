#include "runtime/snapshot.hpp"

#include <fmt/format.h>
#include <hdf5.h>

#include <array>
#include <stdexcept>
#include <vector>

namespace hardrod {

namespace {

const std::array<const char *, 4> kVectorElements = {"position", "velocity", "axis",
                                                     "angular_velocity"};

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

void write_string_attribute(hid_t obj, const char *name, const std::string &value) {
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, value.size() + 1);
  write_attribute(obj, name, type, value.c_str(), 1);
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

}  // namespace

TrajectoryWriter::TrajectoryWriter(const std::string &path, const Scene &scene)
    : n_(scene.n), path_(path) {
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (file < 0) throw std::runtime_error(fmt::format("{}: cannot create the H5MD file", path));
  file_ = file;
  const hid_t h5md = make_group(file, "h5md");
  const int version[2] = {1, 1};
  write_attribute(h5md, "version", H5T_NATIVE_INT, version, 2);
  const hid_t author = make_group(h5md, "author");
  write_string_attribute(author, "name", "hardrod");
  H5Gclose(author);
  const hid_t creator = make_group(h5md, "creator");
  write_string_attribute(creator, "name", "hardrod");
  write_string_attribute(creator, "version", "0.1.0");
  H5Gclose(creator);
  H5Gclose(h5md);

  const hid_t particles = make_group(file, "particles");
  const hid_t all = make_group(particles, "all");
  const hid_t box = make_group(all, "box");
  const int dimension = 3;
  write_attribute(box, "dimension", H5T_NATIVE_INT, &dimension, 1);
  const hid_t strtype = H5Tcopy(H5T_C_S1);
  H5Tset_size(strtype, 9);
  const char boundary[3][9] = {"periodic", "periodic", "periodic"};
  write_attribute(box, "boundary", strtype, boundary, 3);
  H5Tclose(strtype);
  const double edges[3] = {scene.box.length.x, scene.box.length.y, scene.box.length.z};
  const hsize_t three = 3;
  const hid_t space = H5Screate_simple(1, &three, nullptr);
  const hid_t set =
      H5Dcreate2(box, "edges", H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  H5Dwrite(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, edges);
  H5Dclose(set);
  H5Sclose(space);
  H5Gclose(box);
  for (const char *element : kVectorElements) {
    const hid_t g = make_group(all, element);
    make_series(g, "step", H5T_NATIVE_LLONG, {});
    make_series(g, "time", H5T_NATIVE_DOUBLE, {});
    make_series(g, "value", H5T_NATIVE_DOUBLE,
                {static_cast<hsize_t>(scene.n), static_cast<hsize_t>(3)});
    H5Gclose(g);
  }
  const hid_t ids = make_group(all, "id");
  const hsize_t n = static_cast<hsize_t>(scene.n);
  const hid_t idspace = H5Screate_simple(1, &n, nullptr);
  const hid_t idset =
      H5Dcreate2(ids, "value", H5T_NATIVE_LLONG, idspace, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  std::vector<long long> id(static_cast<std::size_t>(scene.n));
  for (std::size_t k = 0; k < id.size(); ++k) id[k] = static_cast<long long>(k);
  H5Dwrite(idset, H5T_NATIVE_LLONG, H5S_ALL, H5S_ALL, H5P_DEFAULT, id.data());
  H5Dclose(idset);
  H5Sclose(idspace);
  H5Gclose(ids);
  H5Gclose(all);
  H5Gclose(particles);

  const hid_t parameters = make_group(file, "parameters");
  write_attribute(parameters, "aspect_ratio", H5T_NATIVE_DOUBLE, &scene.shape.length, 1);
  write_attribute(parameters, "diameter", H5T_NATIVE_DOUBLE, &scene.shape.diameter, 1);
  write_attribute(parameters, "n", H5T_NATIVE_LLONG, &scene.n, 1);
  write_string_attribute(parameters, "shape", scene.shape_name);
  H5Gclose(parameters);
  H5Fflush(file, H5F_SCOPE_GLOBAL);
}

TrajectoryWriter::~TrajectoryWriter() {
  if (file_ >= 0) H5Fclose(static_cast<hid_t>(file_));
}

void TrajectoryWriter::append(const Particles &bodies, long long step, double time) {
  if (static_cast<long long>(bodies.size()) != n_)
    throw std::runtime_error(
        fmt::format("{}: frame has {} bodies, the file {}", path_, bodies.size(), n_));
  const hid_t file = static_cast<hid_t>(file_);
  std::vector<double> buffer(static_cast<std::size_t>(n_) * 3);
  const std::array<std::array<const std::vector<double> *, 3>, 4> fields = {{
      {&bodies.x, &bodies.y, &bodies.z},
      {&bodies.vx, &bodies.vy, &bodies.vz},
      {&bodies.ex, &bodies.ey, &bodies.ez},
      {&bodies.wx, &bodies.wy, &bodies.wz},
  }};
  for (std::size_t e = 0; e < kVectorElements.size(); ++e) {
    const std::string base = std::string("/particles/all/") + kVectorElements[e];
    for (std::size_t i = 0; i < static_cast<std::size_t>(n_); ++i)
      for (std::size_t a = 0; a < 3; ++a) buffer[3 * i + a] = (*fields[e][a])[i];
    append_row(file, base + "/value", H5T_NATIVE_DOUBLE, buffer.data(), frames_, path_);
    append_row(file, base + "/step", H5T_NATIVE_LLONG, &step, frames_, path_);
    append_row(file, base + "/time", H5T_NATIVE_DOUBLE, &time, frames_, path_);
  }
  ++frames_;
  H5Fflush(file, H5F_SCOPE_GLOBAL);  // a killed run keeps every complete frame
}

}  // namespace hardrod
