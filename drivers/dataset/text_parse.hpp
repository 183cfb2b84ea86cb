#pragma once
/// Small strict parsers shared by the dataset readers: every failure throws InputError
/// naming the file and the line or key.
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "drivers/dataset/dataset.hpp"

namespace seavio::drivers::parse {

/// One non-empty, non-comment line of a text file with its 1-based line number.
struct Line {
  int number = 0;
  std::string text;
};

/// All data lines of `path` (lines starting with '#' and blank lines skipped).
/// Throws InputError if the file cannot be opened.
std::vector<Line> readDataLines(const std::string& path);

/// Splits on `sep` (or any whitespace when sep == ' '), trimming each field.
std::vector<std::string> split(const std::string& s, char sep);

/// Strict, finite number; throws InputError "path:line: ...".
double numberField(const std::string& field, const std::string& path, int line, const char* what);
int64_t integerField(const std::string& field, const std::string& path, int line, const char* what);

/// Parses `n` numeric columns of a CSV row (column 0 as int64 timestamp [ns], the rest
/// doubles) and throws on a short row, non-number or NaN.
/// A time in seconds as int64 nanoseconds, rounded; throws InputError "path:line: ..." if
/// it does not fit (|t| above ~292 years), where the conversion would be undefined.
int64_t secondsToNs(double seconds, const std::string& path, int line, const char* what);

void parseRow(const Line& line, const std::string& path, std::size_t n, int64_t& t_ns, std::vector<double>& rest);

/// Loads a YAML file, dropping OpenCV's leading `%YAML:1.0` directive that yaml-cpp rejects.
YAML::Node loadYaml(const std::string& path);
/// `node[key]`, throwing InputError "path: missing key 'key'" when absent.
YAML::Node require(const YAML::Node& node, const std::string& key, const std::string& path);
/// Value conversions that name the key on failure.
double asDouble(const YAML::Node& node, const std::string& key, const std::string& path);
std::vector<double> asDoubles(const YAML::Node& node, const std::string& key, const std::string& path,
                              std::size_t expected);
std::string asString(const YAML::Node& node, const std::string& key, const std::string& path);

/// Throws InputError unless `path` names an existing regular file.
void requireFile(const std::string& path);

}  // namespace seavio::drivers::parse
