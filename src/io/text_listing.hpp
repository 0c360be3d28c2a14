#pragma once
/// Reading the small text files of RGB-D datasets (listings, associations, ground truth):
/// data lines split into whitespace-separated fields, numbers parsed locale-independently.

#include <string>
#include <string_view>
#include <vector>

namespace kfx::io {

/// One data line of a text file.
struct TextLine {
  int line_number = 0;              ///< 1-based line number in the file, for messages
  std::vector<std::string> fields;  ///< whitespace-separated fields
};

/// Reads the data lines of `path`: blank lines and lines starting with '#' are skipped, a
/// trailing '\r' is ignored. `what` names the file's role in messages ("depth listing").
/// Throws kfx::Error naming the file when it cannot be read.
std::vector<TextLine> read_text_lines(const std::string& path, const std::string& what);

/// Parses all of `text` as a finite double ("1305031102.160407", "-2.5e-3"); false otherwise.
bool parse_double(std::string_view text, double* value);

/// Parses a field of `line` as a finite double or throws kfx::Error naming the file, line and
/// field (`what` describes the field, e.g. "timestamp").
double parse_double_field(const TextLine& line, size_t field, const std::string& path,
                          const char* what);

}  // namespace kfx::io
