#include "output/report_page.hpp"

// Generated at build time from src/output/report_page/ (cmake/embed_report_page.cmake).
#include "output/report_page_text.hpp"

namespace kfx::output {

const char* report_page_template() { return generated::kReportPage; }

}  // namespace kfx::output
