# Generates a .cpp defining `std::string_view SYMBOL()` returning the text of INPUT.
file(READ ${INPUT} text)
file(WRITE ${OUTPUT}.tmp "// Generated from ${INPUT} by server/embed_text.cmake. Do not edit.
#include <string_view>
namespace mapdelta::server {
std::string_view ${SYMBOL}() {
  static constexpr std::string_view kText = R\"mdtxt(${text})mdtxt\";
  return kText;
}
}  // namespace mapdelta::server
")
file(COPY_FILE ${OUTPUT}.tmp ${OUTPUT} ONLY_IF_DIFFERENT)
