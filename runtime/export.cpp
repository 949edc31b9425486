// `hardrod export`: H5MD frames with their velocities, the format choice, extended XYZ, the
// checks on --out and the write-then-rename of the output (runtime/export.hpp).
#include "runtime/export.hpp"

#include <fmt/format.h>
#include <hdf5.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <stdexcept>
#include <vector>

#include "runtime/checkpoint.hpp"
#include "runtime/hoomd_gsd.hpp"
#include "runtime/run_files.hpp"
#include "runtime/run_lock.hpp"

namespace hardrod {

namespace fs = std::filesystem;

namespace {

struct File {  // closes on every path out
  hid_t id;
  ~File() {
    if (id >= 0) H5Fclose(id);
  }
};

// Row `frame` of the [frames][n][3] dataset `name`, or nullopt if the file has no such dataset.
std::optional<std::vector<double>> read_vectors(hid_t file, const std::string &name,
                                                long long frame, std::size_t n,
                                                const std::string &path) {
  const std::string group = name.substr(0, name.rfind('/'));
  if (H5Lexists(file, group.c_str(), H5P_DEFAULT) <= 0 ||
      H5Lexists(file, name.c_str(), H5P_DEFAULT) <= 0)
    return std::nullopt;
  const hid_t set = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
  const hid_t space = H5Dget_space(set);
  hsize_t dims[3] = {0, 0, 0};
  const bool shaped = H5Sget_simple_extent_ndims(space) == 3 &&
                      H5Sget_simple_extent_dims(space, dims, nullptr) == 3 &&
                      static_cast<long long>(dims[0]) > frame && dims[1] == n && dims[2] == 3;
  std::vector<double> out(3 * n);
  herr_t status = -1;
  if (shaped) {
    const hsize_t start[3] = {static_cast<hsize_t>(frame), 0, 0}, count[3] = {1, n, 3};
    H5Sselect_hyperslab(space, H5S_SELECT_SET, start, nullptr, count, nullptr);
    const hsize_t total = 3 * n;
    const hid_t memory = H5Screate_simple(1, &total, nullptr);
    status = H5Dread(set, H5T_NATIVE_DOUBLE, memory, space, H5P_DEFAULT, out.data());
    H5Sclose(memory);
  }
  H5Sclose(space);
  H5Dclose(set);
  if (!shaped)
    throw std::runtime_error(
        fmt::format("{}: {} must have shape [frames][{}][3] with frame {}", path, name, n, frame));
  if (status < 0) throw std::runtime_error(fmt::format("{}: cannot read {}", path, name));
  for (double v : out)
    if (!std::isfinite(v))
      throw std::runtime_error(fmt::format("{}: {} frame {}: not finite", path, name, frame));
  return out;
}

double read_parameter(hid_t file, const char *name, const std::string &path) {
  double value = NAN;
  if (H5Aexists_by_name(file, "/parameters", name, H5P_DEFAULT) > 0) {
    const hid_t attr = H5Aopen_by_name(file, "/parameters", name, H5P_DEFAULT, H5P_DEFAULT);
    if (H5Aread(attr, H5T_NATIVE_DOUBLE, &value) < 0) value = NAN;
    H5Aclose(attr);
  }
  if (!std::isfinite(value) || value < 0)
    throw std::runtime_error(fmt::format(
        "{}: /parameters attribute {} missing or not a number >= 0 (the rod shape)", path, name));
  return value;
}

// Writes `out` through `write(tmp)` into `out`.tmp, then renames it into place. A `out`.tmp
// left by an export that was killed is unlinked first, so that a hard link to it elsewhere
// keeps its content (check_export_target refused anything there but a regular file).
template <typename Write>
void write_then_rename(const std::string &out, Write write) {
  const std::string tmp = out + ".tmp";
  try {
    std::error_code stale;
    fs::remove(tmp, stale);
    write(tmp);
    fs::rename(tmp, out);
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
}

// What `write(stream)` produces, on standard output (`out` empty) or in the file `out`.
template <typename Write>
void write_text(const std::string &out, Write write) {
  if (out.empty()) {
    write(std::cout);
    std::cout.flush();
    return;
  }
  write_then_rename(out, [&](const std::string &tmp) {
    errno = 0;
    std::ofstream stream(tmp);
    if (!stream) {
      // The reason: usually a folder that does not exist, or one that may not be written.
      const fs::path folder =
          fs::path(tmp).parent_path().empty() ? "." : fs::path(tmp).parent_path();
      std::error_code ec;
      const std::string why = !fs::is_directory(folder, ec)
                                  ? fmt::format("no folder {}", folder.string())
                                  : (errno ? std::strerror(errno) : "not writable");
      throw std::runtime_error(fmt::format("{}: cannot create ({})", tmp, why));
    }
    write(stream);
    stream.close();
    if (!stream) throw std::runtime_error(fmt::format("{}: cannot write (disk full?)", tmp));
  });
}

bool is_run_file(const std::string &name) { return is_run_file_name(name) || name == kLockFile; }

// Refuses `path` (`out` or its temporary file) if something is there that is not a regular
// file: renaming over it would replace a device, a FIFO or a link with a file.
void refuse_unless_regular(const std::string &out, const fs::path &path, bool temporary) {
  std::error_code ec;
  const fs::file_type type = fs::symlink_status(path, ec).type();
  if (ec || type == fs::file_type::not_found || type == fs::file_type::regular) return;
  const std::string what = temporary ? "its temporary file " + path.string() : "it";
  std::string kind = "not a regular file";
  if (type == fs::file_type::directory) kind = "a directory";
  if (type == fs::file_type::character || type == fs::file_type::block) kind = "a device";
  if (type == fs::file_type::fifo) kind = "a FIFO (named pipe)";
  if (type == fs::file_type::socket) kind = "a socket";
  if (type == fs::file_type::symlink) {
    const fs::path target = fs::read_symlink(path, ec);
    throw std::invalid_argument(fmt::format(
        "--out {}: {} is a symbolic link (to {}); export does not write through links: give "
        "the file's own path (nothing was changed)",
        out, what, ec ? std::string("?") : target.string()));
  }
  throw std::invalid_argument(fmt::format(
      "--out {}: {} is {}, not a regular file; export writes only regular files (nothing was "
      "changed)",
      out, what, kind));
}

}  // namespace

ExportFormat choose_export_format(const std::string &format, const std::string &out) {
  if (format == "xyz") return ExportFormat::kXyz;
  if (format == "gsd") return ExportFormat::kGsd;
  if (format == "pov") return ExportFormat::kPov;
  if (!format.empty())
    throw std::invalid_argument(fmt::format(
        "--format {}: must be xyz (extended XYZ), gsd (HOOMD's GSD) or pov (POV-Ray)", format));
  const std::string extension = fs::path(out).extension().string();
  if (extension == ".gsd") return ExportFormat::kGsd;
  if (extension == ".pov") return ExportFormat::kPov;
  if (extension == ".h5" || extension == ".hdf5" || extension == ".h5md")
    throw std::invalid_argument(fmt::format(
        "--out {}: a {} name is an HDF5 file's, and export writes none; name the file .xyz, "
        ".gsd or .pov, or pass --format xyz to write extended XYZ under this name",
        out, extension));
  return ExportFormat::kXyz;
}

void check_export_target(const std::string &input, const std::string &out) {
  const fs::path target = fs::absolute(out);
  refuse_unless_regular(out, target, false);
  refuse_unless_regular(out, target.string() + ".tmp", true);
  if (same_file(target, input))
    throw std::invalid_argument(fmt::format(
        "--out {}: is the input file itself; export to another file (nothing was changed)", out));
  const fs::path run_dir = fs::absolute(input).parent_path();
  const std::string name = target.filename().string();
  if (is_run_file(name) && same_file(target.parent_path(), run_dir))
    throw std::invalid_argument(fmt::format(
        "--out {}: {} is one of the run's own files in {}; export to another name (nothing was "
        "changed)",
        out, name, run_dir.string()));
  std::error_code ec;
  for (const fs::directory_entry &e : fs::directory_iterator(run_dir, ec))
    if (is_run_file(e.path().filename().string()) && same_file(e.path(), target))
      throw std::invalid_argument(fmt::format(
          "--out {}: is the same file as the run's {}; export to another file (nothing was "
          "changed)",
          out, e.path().string()));
}

Shape read_h5md_shape(const std::string &path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  File file{H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT)};
  if (file.id < 0) throw std::runtime_error(fmt::format("{}: cannot open", path));
  Shape shape;
  shape.length = read_parameter(file.id, "aspect_ratio", path);
  shape.diameter = read_parameter(file.id, "diameter", path);
  if (shape.diameter <= 0)
    throw std::runtime_error(fmt::format("{}: /parameters diameter = 0", path));
  return shape;
}

SnapshotFrame read_h5md_frame_with_velocities(const std::string &path, long long frame) {
  SnapshotFrame f = read_h5md_frame(path, frame);
  File file{H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT)};
  if (file.id < 0) throw std::runtime_error(fmt::format("{}: cannot open", path));
  Particles &p = f.bodies;
  const std::size_t n = p.size();
  const auto v = read_vectors(file.id, "/particles/all/velocity/value", f.frame, n, path);
  const auto w = read_vectors(file.id, "/particles/all/angular_velocity/value", f.frame, n, path);
  for (std::size_t i = 0; i < n; ++i) {
    if (v) p.set_velocity(i, {(*v)[3 * i], (*v)[3 * i + 1], (*v)[3 * i + 2]});
    if (w) p.set_angular_velocity(i, {(*w)[3 * i], (*w)[3 * i + 1], (*w)[3 * i + 2]});
  }
  return f;
}

// Frame k with its velocities, checked against the state checksum it was written with (files
// that carry one): a damaged file is refused rather than exported.
SnapshotFrame read_checked_frame(const std::string &path, long long k) {
  SnapshotFrame f = read_h5md_frame_with_velocities(path, k);
  const std::optional<std::uint64_t> stored = read_frame_checksum(path, f.frame);
  const std::uint64_t now = body_hash(f.bodies);
  if (stored && now != *stored)
    throw std::runtime_error(
        fmt::format("{}: frame {} is damaged: its data hash to {:016x}, it was written as {:016x} "
                    "(/observables/state_checksum)",
                    path, f.frame, now, *stored));
  return f;
}

std::string extended_xyz(const SnapshotFrame &f, const Shape &shape) {
  const Vec3 &l = f.box.length;
  std::string out = fmt::format(
      "{}\nLattice=\"{:.17g} 0 0 0 {:.17g} 0 0 0 {:.17g}\" Origin=\"0 0 0\" pbc=\"T T T\" "
      "Properties=species:S:1:pos:R:3:orientation:R:4:aspherical_shape:R:3:id:I:1 "
      "step={} frame={}\n",
      f.bodies.size(), l.x, l.y, l.z, f.step, f.frame);
  const double r = shape.radius();
  for (std::size_t i = 0; i < f.bodies.size(); ++i) {
    const Vec3 x = f.box.wrap(f.bodies.position(i));
    const Quaternion q = quaternion_from_axis(f.bodies.axis(i));
    out += fmt::format("X {:.10f} {:.10f} {:.10f} {:.12f} {:.12f} {:.12f} {:.12f} {} {} {} {}\n",
                       x.x, x.y, x.z, q[1], q[2], q[3], q[0], r, r, shape.length, i);
  }
  return out;
}

void export_trajectory(const std::string &h5md, std::optional<long long> frame,
                       const std::string &out, ExportFormat format,
                       const std::optional<PovSlab> &slab) {
  if (format == ExportFormat::kGsd && out.empty())
    throw std::invalid_argument("--format gsd needs --out FILE.gsd (the file is binary)");
  if (slab && format != ExportFormat::kPov)
    throw std::invalid_argument("--slab: only for a POV-Ray scene (--format pov)");
  if (!out.empty()) check_export_target(h5md, out);
  const Shape shape = read_h5md_shape(h5md);
  if (format == ExportFormat::kPov) {
    const SnapshotFrame f = read_checked_frame(h5md, frame.value_or(-1));
    const std::string source = fmt::format("{} frame {}", h5md, f.frame);
    write_text(out, [&](std::ostream &stream) { stream << pov_scene(f, shape, slab, source); });
    return;
  }
  const long long frames = read_h5md_frame(h5md, frame.value_or(-1)).frames;
  const long long first = frame ? (*frame < 0 ? frames + *frame : *frame) : 0;
  const long long last = frame ? first + 1 : frames;
  if (format == ExportFormat::kGsd) {
    write_then_rename(out, [&](const std::string &tmp) {
      gsd::Writer writer(tmp, "hardrod", "hoomd", gsd::make_version(1, 4));
      for (long long k = first; k < last; ++k)
        append_hoomd_frame(writer, read_checked_frame(h5md, k), shape, k == first);
      writer.finish();
    });
    return;
  }
  write_text(out, [&](std::ostream &stream) {
    for (long long k = first; k < last; ++k)
      stream << extended_xyz(read_checked_frame(h5md, k), shape);
  });
}

}  // namespace hardrod
