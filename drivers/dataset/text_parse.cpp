#include "drivers/dataset/text_parse.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace seavio::drivers::parse {
namespace {

// The same characters std::isspace and `operator>>` skip, so a line that is blank to split(' ')
// is blank here too (else a lone form feed passes as data and leaves split() empty).
constexpr const char* kSpace = " \t\n\v\f\r";

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(kSpace);
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(kSpace);
  return s.substr(b, e - b + 1);
}

std::string where(const std::string& path, int line) { return path + ":" + std::to_string(line) + ": "; }

}  // namespace

void requireFile(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw InputError(path + ": missing file");
}

std::vector<Line> readDataLines(const std::string& path) {
  requireFile(path);
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open file");
  std::vector<Line> lines;
  std::string s;
  int n = 0;
  while (std::getline(in, s)) {
    ++n;
    const std::string t = trim(s);
    if (t.empty() || t[0] == '#') continue;
    lines.push_back({n, t});
  }
  if (in.bad()) throw InputError(path + ": read error");
  return lines;
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  if (sep == ' ') {
    std::istringstream is(s);
    std::string f;
    while (is >> f) out.push_back(f);
    return out;
  }
  std::string f;
  std::istringstream is(s);
  while (std::getline(is, f, sep)) out.push_back(trim(f));
  if (!s.empty() && s.back() == sep) out.emplace_back();
  return out;
}

double numberField(const std::string& field, const std::string& path, int line, const char* what) {
  if (field.empty()) throw InputError(where(path, line) + "empty " + what);
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(field.c_str(), &end);
  if (end != field.c_str() + field.size() || errno == ERANGE)
    throw InputError(where(path, line) + "'" + field + "' is not a number (" + what + ")");
  if (!std::isfinite(v)) throw InputError(where(path, line) + "non-finite " + what + " '" + field + "'");
  return v;
}

int64_t integerField(const std::string& field, const std::string& path, int line, const char* what) {
  if (field.empty()) throw InputError(where(path, line) + "empty " + what);
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(field.c_str(), &end, 10);
  if (end != field.c_str() + field.size() || errno == ERANGE)
    throw InputError(where(path, line) + "'" + field + "' is not an integer (" + what + ")");
  return static_cast<int64_t>(v);
}

int64_t secondsToNs(double seconds, const std::string& path, int line, const char* what) {
  // 9.2e9 s is int64's limit in ns; beyond it llround's result is unspecified.
  if (!(std::fabs(seconds) < 9.2e9))
    throw InputError(where(path, line) + what + " " + std::to_string(seconds) + " is out of range");
  return std::llround(seconds * 1e9);
}

void parseRow(const Line& line, const std::string& path, std::size_t n, int64_t& t_ns, std::vector<double>& rest) {
  const auto f = split(line.text, ',');
  if (f.size() < n)
    throw InputError(where(path, line.number) + "short row: " + std::to_string(f.size()) + " columns, expected " +
                     std::to_string(n));
  t_ns = integerField(f[0], path, line.number, "timestamp [ns]");
  rest.resize(n - 1);
  for (std::size_t i = 1; i < n; ++i) rest[i - 1] = numberField(f[i], path, line.number, "value");
}

YAML::Node loadYaml(const std::string& path) {
  requireFile(path);
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open file");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  int skipped = 0;
  if (text.rfind("%YAML:", 0) == 0) {
    // OpenCV writes "%YAML:1.0", which is not a valid YAML directive.
    const auto nl = text.find('\n');
    text = nl == std::string::npos ? std::string() : text.substr(nl + 1);
    skipped = 1;
  }
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(path + ":" + std::to_string(e.mark.line + 1 + skipped) + ": YAML error: " + e.msg);
  }
}

YAML::Node require(const YAML::Node& node, const std::string& key, const std::string& path) {
  if (!node.IsMap() || !node[key]) throw InputError(path + ": missing key '" + key + "'");
  return node[key];
}

double asDouble(const YAML::Node& node, const std::string& key, const std::string& path) {
  try {
    const double v = require(node, key, path).as<double>();
    if (!std::isfinite(v)) throw InputError(path + ": key '" + key + "' is not finite");
    return v;
  } catch (const YAML::Exception&) {
    throw InputError(path + ": key '" + key + "' is not a number");
  }
}

std::vector<double> asDoubles(const YAML::Node& node, const std::string& key, const std::string& path,
                              std::size_t expected) {
  std::vector<double> v;
  try {
    v = require(node, key, path).as<std::vector<double>>();
  } catch (const YAML::Exception&) {
    throw InputError(path + ": key '" + key + "' is not a list of numbers");
  }
  if (v.size() != expected)
    throw InputError(path + ": key '" + key + "' has " + std::to_string(v.size()) + " values, expected " +
                     std::to_string(expected));
  for (double x : v)
    if (!std::isfinite(x)) throw InputError(path + ": key '" + key + "' holds a non-finite value");
  return v;
}

std::string asString(const YAML::Node& node, const std::string& key, const std::string& path) {
  try {
    return require(node, key, path).as<std::string>();
  } catch (const YAML::Exception&) {
    throw InputError(path + ": key '" + key + "' is not a string");
  }
}

}  // namespace seavio::drivers::parse
