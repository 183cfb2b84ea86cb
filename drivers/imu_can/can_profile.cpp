#include "drivers/imu_can/can_profile.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <sstream>

namespace seavio::drivers {
namespace {

struct ProfileError {
  std::string msg;
};

[[noreturn]] void fail(const std::string& origin, const YAML::Node& n, const std::string& key,
                       const std::string& what) {
  const int line = n.Mark().line >= 0 ? n.Mark().line + 1 : 0;
  throw ProfileError{origin + ":" + std::to_string(line) + ": " + key + ": " + what};
}

template <typename T>
T scalar(const std::string& origin, const YAML::Node& parent, const std::string& key, const std::string& path) {
  const YAML::Node n = parent[key];
  if (!n) fail(origin, parent, path + key, "missing");
  if (!n.IsScalar()) fail(origin, n, path + key, "must be a scalar");
  try {
    return n.as<T>();
  } catch (const YAML::Exception&) {
    fail(origin, n, path + key, "invalid value '" + n.Scalar() + "'");
  }
}

CanField field(const std::string& origin, const YAML::Node& parent, const std::string& key, const std::string& path) {
  const YAML::Node n = parent[key];
  const std::string p = path + key;
  if (!n || !n.IsMap()) fail(origin, n ? n : parent, p, "missing or not a map");
  CanField f;
  const uint32_t id = scalar<uint32_t>(origin, n, "id", p + ".");
  f.extended = n["extended"] ? scalar<bool>(origin, n, "extended", p + ".") : false;
  if (id > (f.extended ? 0x1FFFFFFFu : 0x7FFu)) fail(origin, n["id"], p + ".id", "out of range for the id kind");
  f.id = id;
  const std::string type = scalar<std::string>(origin, n, "type", p + ".");
  if (type == "int8")
    f.type = CanFieldType::kInt8;
  else if (type == "uint8")
    f.type = CanFieldType::kUint8;
  else if (type == "int16")
    f.type = CanFieldType::kInt16;
  else if (type == "uint16")
    f.type = CanFieldType::kUint16;
  else if (type == "int32")
    f.type = CanFieldType::kInt32;
  else if (type == "uint32")
    f.type = CanFieldType::kUint32;
  else
    fail(origin, n["type"], p + ".type", "must be int8|uint8|int16|uint16|int32|uint32, got '" + type + "'");
  f.offset = scalar<int>(origin, n, "offset", p + ".");
  if (f.offset < 0 || f.offset + f.size() > 8)
    fail(origin, n["offset"], p + ".offset", "field does not fit in 8 data bytes");
  const std::string endian = n["endian"] ? scalar<std::string>(origin, n, "endian", p + ".") : "little";
  if (endian != "little" && endian != "big") fail(origin, n["endian"], p + ".endian", "must be little or big");
  f.big_endian = endian == "big";
  f.scale = scalar<double>(origin, n, "scale", p + ".");
  if (f.scale == 0.0 || !std::isfinite(f.scale)) fail(origin, n["scale"], p + ".scale", "must be a non-zero number");
  f.bias = n["bias"] ? scalar<double>(origin, n, "bias", p + ".") : 0.0;
  if (!std::isfinite(f.bias)) fail(origin, n["bias"], p + ".bias", "must be finite");
  return f;
}

}  // namespace

int CanField::size() const {
  switch (type) {
    case CanFieldType::kInt8:
    case CanFieldType::kUint8:
      return 1;
    case CanFieldType::kInt16:
    case CanFieldType::kUint16:
      return 2;
    case CanFieldType::kInt32:
    case CanFieldType::kUint32:
      return 4;
  }
  return 0;
}

std::optional<CanProfile> parseCanProfile(const std::string& yaml_text, const std::string& origin, std::string& error) {
  try {
    const YAML::Node root = YAML::Load(yaml_text);
    if (!root.IsMap()) fail(origin, root, "(root)", "must be a map");
    CanProfile p;
    p.name = scalar<std::string>(origin, root, "name", "");
    static const char* kAxes[3] = {"x", "y", "z"};
    for (const char* group : {"gyro", "accel"}) {
      const YAML::Node g = root[group];
      if (!g || !g.IsMap()) fail(origin, g ? g : root, group, "missing or not a map with x, y, z");
      for (int i = 0; i < 3; ++i) {
        CanField f = field(origin, g, kAxes[i], std::string(group) + ".");
        (std::string(group) == "gyro" ? p.gyro : p.accel)[i] = f;
      }
    }
    if (root["timestamp"]) p.timestamp = field(origin, root, "timestamp", "");
    const YAML::Node e = root["emit_on"];
    if (!e || !e.IsMap()) fail(origin, e ? e : root, "emit_on", "missing or not a map with id");
    p.emit_on_id = scalar<uint32_t>(origin, e, "id", "emit_on.");
    p.emit_on_extended = e["extended"] ? scalar<bool>(origin, e, "extended", "emit_on.") : false;
    bool used = false;
    for (const auto* arr : {&p.gyro, &p.accel})
      for (const CanField& f : *arr) used |= f.id == p.emit_on_id && f.extended == p.emit_on_extended;
    if (!used) fail(origin, e, "emit_on.id", "is not the id of any gyro or accel field");
    return p;
  } catch (const ProfileError& ex) {
    error = ex.msg;
  } catch (const YAML::Exception& ex) {
    error = origin + ":" + std::to_string(ex.mark.line + 1) + ": YAML syntax: " + ex.msg;
  }
  return std::nullopt;
}

std::optional<CanProfile> loadCanProfile(const std::string& path, std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = path + ": cannot open CAN profile";
    return std::nullopt;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  return parseCanProfile(ss.str(), path, error);
}

}  // namespace seavio::drivers
