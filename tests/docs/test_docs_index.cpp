/// The users' documentation index: docs/README.md lists every page of docs/, and every page it
/// links exists.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <string>

namespace kfx {
namespace {

namespace fs = std::filesystem;

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

TEST(DocsIndex, ListsEveryPageAndLinksOnlyPagesThatExist) {
  const fs::path docs = fs::path(KFX_SOURCE_DIR) / "docs";
  const std::string index = read_text(docs / "README.md");
  ASSERT_FALSE(index.empty()) << docs / "README.md";
  for (const auto& entry : fs::directory_iterator(docs)) {
    const std::string name = entry.path().filename().string();
    if (entry.path().extension() != ".md" || name == "README.md") continue;
    EXPECT_NE(index.find("](" + name + ")"), std::string::npos)
        << "docs/README.md does not list " << name;
  }
  const std::regex link(R"(\]\(([^)#]+)\))");
  for (auto it = std::sregex_iterator(index.begin(), index.end(), link);
       it != std::sregex_iterator(); ++it) {
    EXPECT_TRUE(fs::exists(docs / (*it)[1].str())) << "docs/README.md links " << (*it)[1];
  }
}

}  // namespace
}  // namespace kfx
