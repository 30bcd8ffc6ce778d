// Saving and restoring the Data Product Manager: products.json (the index, with small values
// inline) and one file per sample of the types that the registry saves as files (PLY for point
// clouds and meshes, the MCAP message for the rest). The format is in docs/dfpc.md.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "cdff/dfpc/data_product_manager.hpp"
#include "cdff/types/codec/codec.hpp"

namespace cdff::dfpc {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kFormatVersion = 1;

/// The extension of a sample file of `type`.
std::string_view fileExtension(const TypeInfo& type) {
  if (type.product == ProductForm::kPly) return "ply";
  return type.encoding == MessageEncoding::kJson ? "json" : "pb";
}

std::string folderName(std::size_t index, const std::string& product) {
  std::string safe;
  for (char c : product) safe += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  return fmt::format("{:03}_{}", index, safe);
}

Status writeFile(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out || !out.write(bytes.data(), static_cast<std::streamsize>(bytes.size())))
    return ioError("{}: cannot write ({} bytes); expected a writable directory", path.string(),
                   bytes.size());
  return Status::ok();
}

Result<std::string> readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return notFound("{}: cannot open; expected the file that save() wrote", path.string());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

Status DataProductManager::save(const std::string& directory) const {
  std::error_code ec;
  fs::create_directories(directory, ec);
  if (ec) return ioError("{}: cannot create the product directory: {}", directory, ec.message());
  json index = {{"format", "cdff-data-products"}, {"version", kFormatVersion}};
  index["products"] = json::array();
  std::vector<std::string> problems;
  const std::vector<std::string> product_names = names();
  for (std::size_t i = 0; i < product_names.size(); ++i) {
    const std::string& name = product_names[i];
    std::shared_ptr<Series> s = find(name);
    if (!s) continue;
    std::shared_lock lock(s->mutex);
    json entry = {{"name", name}, {"type", std::string(s->type.name())}, {"history", s->limit}};
    entry["samples"] = json::array();
    const TypeInfo& type = s->type.info();
    const std::string folder = folderName(i, name);
    for (std::size_t k = 0; k < s->samples.size(); ++k) {
      const Product& p = s->samples[k];
      json sample = {{"stamp_us", p.stamp}};
      codec::ProductRecord record;
      if (Status saved = type.save_product(p.value.raw(), p.stamp, record); !saved) {
        problems.push_back(
            saved.withContext(fmt::format("product '{}' sample {}", name, k)).message());
        continue;
      }
      if (type.product == ProductForm::kInline) {
        sample["value"] = std::move(record.json);
      } else {
        fs::create_directories(fs::path(directory) / folder, ec);
        const std::string file = fmt::format("{}/{:06}.{}", folder, k, fileExtension(type));
        Status written = writeFile(fs::path(directory) / file, record.file);
        if (!written) {
          problems.push_back(written.message());
          continue;
        }
        if (type.product == ProductForm::kPly) sample.update(record.json);
        sample["file"] = file;
      }
      entry["samples"].push_back(std::move(sample));
    }
    index["products"].push_back(std::move(entry));
  }
  // The index last, through a rename: a reader never sees an index naming files not yet written.
  const fs::path tmp = fs::path(directory) / "products.json.tmp";
  CDFF_RETURN_IF_ERROR(writeFile(tmp, index.dump(1)));
  fs::rename(tmp, fs::path(directory) / "products.json", ec);
  if (ec) return ioError("{}: cannot write products.json: {}", directory, ec.message());
  if (!problems.empty())
    return ioError("{}: saved all but: {}", directory, fmt::join(problems, "; "));
  return Status::ok();
}

Status DataProductManager::restore(const std::string& directory) {
  const fs::path index_path = fs::path(directory) / "products.json";
  Result<std::string> text = readFile(index_path);
  if (!text) return text.status();
  json index;
  try {
    index = json::parse(*text);
  } catch (const json::exception& e) {
    return Status(StatusCode::kCorruptData,
                  fmt::format("{}: not valid JSON: {}", index_path.string(), e.what()));
  }
  if (index.value("format", "") != "cdff-data-products" || index.value("version", 0) != 1)
    return Status(
        StatusCode::kCorruptData,
        fmt::format("{}: expected format 'cdff-data-products' version 1", index_path.string()));
  // Decode everything first: a failed restore leaves the manager as it was.
  struct Decoded {
    std::string name;
    std::size_t limit;
    std::vector<std::pair<Timestamp, Value>> samples;
  };
  std::vector<Decoded> decoded;
  const auto corrupt = [&](const std::string& what) {
    return Status(
        StatusCode::kCorruptData,
        fmt::format("{}: {}; expected the index that save() writes", index_path.string(), what));
  };
  try {
    for (const json& entry : index.at("products")) {
      Decoded d;
      d.name = entry.at("name").get<std::string>();
      const std::string type_name = entry.at("type").get<std::string>();
      const TypeId type = findType(type_name);
      if (!type)
        return corrupt(
            fmt::format("product '{}' has type '{}', which is not a data type of the "
                        "registry; expected one of {}",
                        d.name, type_name, typeNames()));
      d.limit = entry.at("history").get<std::size_t>();
      for (const json& sample : entry.at("samples")) {
        const Timestamp stamp = sample.at("stamp_us").get<Timestamp>();
        codec::ProductRecord record;
        std::string where = index_path.string();
        if (type.info().product == ProductForm::kInline) {
          record.json = sample.at("value");
        } else {
          const fs::path file = fs::path(directory) / sample.at("file").get<std::string>();
          Result<std::string> bytes = readFile(file);
          if (!bytes) return bytes.status();
          record.file = std::move(bytes).value();
          record.json = sample;
          where = file.string();
        }
        Result<Value> value = type.info().load_product(record);
        if (!value)
          return Status(StatusCode::kCorruptData,
                        fmt::format("{}: product '{}' sample at {} us: {}", where, d.name, stamp,
                                    value.status().message()));
        d.samples.emplace_back(stamp, std::move(value).value());
      }
      decoded.push_back(std::move(d));
    }
  } catch (const std::exception& e) {
    return corrupt(e.what());
  }
  {
    std::unique_lock lock(mutex_);
    series_.clear();
  }
  for (Decoded& d : decoded) {
    CDFF_RETURN_IF_ERROR(setHistoryLimit(d.name, std::max<std::size_t>(d.limit, 1)));
    for (auto& [stamp, value] : d.samples)
      CDFF_RETURN_IF_ERROR(publish(d.name, stamp, std::move(value)));
  }
  return Status::ok();
}

}  // namespace cdff::dfpc
