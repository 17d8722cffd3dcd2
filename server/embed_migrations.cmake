# Generates a .cpp that embeds every NNN_name.sql of a folder as a raw string literal.
# Inputs: MIGRATIONS_DIR, OUTPUT; SYMBOL (default EmbeddedMigrations): the function that returns
# them (a second backend with its own folder embeds it under its own name, declared beside
# EmbeddedMigrations in migrations.hpp).
if(NOT SYMBOL)
  set(SYMBOL EmbeddedMigrations)
endif()
file(GLOB sql_files ${MIGRATIONS_DIR}/[0-9][0-9][0-9]_*.sql)
list(SORT sql_files)
set(body "")
foreach(f ${sql_files})
  get_filename_component(name ${f} NAME_WE)
  string(SUBSTRING ${name} 0 3 num)
  math(EXPR version "${num}")
  file(READ ${f} sql)
  string(APPEND body "    {${version}, \"${name}\", R\"mdsql(${sql})mdsql\"},\n")
endforeach()
file(WRITE ${OUTPUT}.tmp "// Generated from migrations/*.sql by server/embed_migrations.cmake. Do not edit.
#include \"migrations.hpp\"
namespace mapdelta::server {
const std::vector<Migration>& ${SYMBOL}() {
  static const std::vector<Migration> kAll = {
${body}  };
  return kAll;
}
}  // namespace mapdelta::server
")
file(COPY_FILE ${OUTPUT}.tmp ${OUTPUT} ONLY_IF_DIFFERENT)
