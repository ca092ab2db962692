// The readers of io/draws_netcdf.hpp: enough of the C API to look into a draws file.
#include <netcdf.h>

#include <filesystem>

#include "io/draws_netcdf.hpp"
#include "util/errors.hpp"

namespace ssrfleet::io {

namespace {

class NcReadFile {
 public:
  explicit NcReadFile(const std::string& path) : path_(path) {
    if (!std::filesystem::exists(path)) throw MissingInputError("cannot open '" + path + "': no such file");
    const int status = nc_open(path.c_str(), NC_NOWRITE, &id_);
    if (status != NC_NOERR)
      throw DataError(path, 0, "format", std::string("not a netCDF file: ") + nc_strerror(status));
  }
  ~NcReadFile() { nc_close(id_); }
  NcReadFile(const NcReadFile&) = delete;
  NcReadFile& operator=(const NcReadFile&) = delete;
  int id() const { return id_; }
  void check(int status, const std::string& field) const {
    if (status != NC_NOERR) throw DataError(path_, 0, field, nc_strerror(status));
  }
  int group(const std::string& name) const {
    int g = -1;
    check(nc_inq_ncid(id_, name.c_str(), &g), name);
    return g;
  }
  int variable(int group, const std::string& field, const std::string& name) const {
    int v = -1;
    check(nc_inq_varid(group, name.c_str(), &v), field);
    return v;
  }

 private:
  std::string path_;
  int id_ = -1;
};

}  // namespace

std::vector<std::string> netcdf_groups(const std::string& path) {
  NcReadFile file(path);
  int count = 0;
  file.check(nc_inq_grps(file.id(), &count, nullptr), "groups");
  std::vector<int> ids(static_cast<std::size_t>(count));
  if (count > 0) file.check(nc_inq_grps(file.id(), &count, ids.data()), "groups");
  std::vector<std::string> names;
  for (int g : ids) {
    char name[NC_MAX_NAME + 1];
    file.check(nc_inq_grpname(g, name), "groups");
    names.emplace_back(name);
  }
  return names;
}

NetcdfVariable read_netcdf_variable(const std::string& path, const std::string& group,
                                    const std::string& name) {
  NcReadFile file(path);
  const std::string field = group + "/" + name;
  const int g = file.group(group);
  const int v = file.variable(g, field, name);
  int ndims = 0;
  file.check(nc_inq_varndims(g, v, &ndims), field);
  std::vector<int> dim_ids(static_cast<std::size_t>(ndims));
  file.check(nc_inq_vardimid(g, v, dim_ids.data()), field);
  NetcdfVariable out;
  std::size_t total = 1;
  for (int d : dim_ids) {
    char dim_name[NC_MAX_NAME + 1];
    std::size_t length = 0;
    file.check(nc_inq_dim(g, d, dim_name, &length), field);
    out.dims.emplace_back(dim_name);
    out.shape.push_back(length);
    total *= length;
  }
  nc_type type = NC_NAT;
  file.check(nc_inq_vartype(g, v, &type), field);
  if (type == NC_STRING || type == NC_CHAR) throw DataError(path, 0, field, "holds text, not numbers");
  out.values.resize(total);
  if (total > 0) file.check(nc_get_var_double(g, v, out.values.data()), field);  // the C API converts
  return out;
}

std::vector<std::string> read_netcdf_strings(const std::string& path, const std::string& group,
                                             const std::string& name) {
  NcReadFile file(path);
  const std::string field = group + "/" + name;
  const int g = file.group(group);
  const int v = file.variable(g, field, name);
  nc_type type = NC_NAT;
  int ndims = 0;
  file.check(nc_inq_vartype(g, v, &type), field);
  file.check(nc_inq_varndims(g, v, &ndims), field);
  // Characters over (labels, width), NUL-padded, as write_draws_netcdf writes them.
  if (type != NC_CHAR || ndims != 2) throw DataError(path, 0, field, "is not a list of strings");
  int dims[2] = {-1, -1};
  file.check(nc_inq_vardimid(g, v, dims), field);
  std::size_t count = 0, width = 0;
  file.check(nc_inq_dimlen(g, dims[0], &count), field);
  file.check(nc_inq_dimlen(g, dims[1], &width), field);
  std::string block(count * width, '\0');
  if (!block.empty()) file.check(nc_get_var_text(g, v, block.data()), field);
  std::vector<std::string> out;
  for (std::size_t i = 0; i < count; ++i) {
    const std::string cell = block.substr(i * width, width);
    out.push_back(cell.substr(0, cell.find('\0')));
  }
  return out;
}

std::string read_netcdf_text_attribute(const std::string& path, const std::string& group,
                                       const std::string& name) {
  NcReadFile file(path);
  const std::string field = group + "/@" + name;
  const int g = group.empty() ? file.id() : file.group(group);
  nc_type type = NC_NAT;
  std::size_t length = 0;
  file.check(nc_inq_att(g, NC_GLOBAL, name.c_str(), &type, &length), field);
  if (type != NC_CHAR) throw DataError(path, 0, field, "is not text");
  std::string text(length, '\0');
  if (length > 0) file.check(nc_get_att_text(g, NC_GLOBAL, name.c_str(), text.data()), field);
  return text;
}

}  // namespace ssrfleet::io
