# The viewer's page (src/penumbra/viewer/page/: index.html, style.css, js/*.js) compiled into the library:
# penumbra serves it itself (viewer_server.cpp), from a table of path, MIME type and content generated
# here into ${PROJECT_BINARY_DIR}/generated/viewer_page.cpp. A file added or removed re-runs the
# configure (the glob's CONFIGURE_DEPENDS), and so does a file edited (CMAKE_CONFIGURE_DEPENDS); the
# generated file is rewritten only when its content changes. index.html is served at /, every other
# file at its path under page/.
set(PENUMBRA_PAGE_DIR ${PROJECT_SOURCE_DIR}/src/penumbra/viewer/page)
set(PENUMBRA_PAGE_DELIMITER "penumbra_page")  # of the raw string literals: R"penumbra_page(...)penumbra_page"
file(GLOB_RECURSE PENUMBRA_PAGE_FILES LIST_DIRECTORIES false RELATIVE ${PENUMBRA_PAGE_DIR} CONFIGURE_DEPENDS ${PENUMBRA_PAGE_DIR}/*)
list(SORT PENUMBRA_PAGE_FILES)
set(PENUMBRA_VIEWER_PAGE_FILES "")
foreach(file IN LISTS PENUMBRA_PAGE_FILES)
  get_filename_component(name ${file} NAME)
  if(name MATCHES "^\\." OR name MATCHES "~$")  # an editor's swap or backup file
    continue()
  endif()
  if(file MATCHES "\\.html$")
    set(type "text/html; charset=utf-8")
  elseif(file MATCHES "\\.css$")
    set(type "text/css; charset=utf-8")
  elseif(file MATCHES "\\.js$")
    set(type "text/javascript; charset=utf-8")
  else()
    message(FATAL_ERROR "src/penumbra/viewer/page/${file}: the viewer serves .html, .css and .js files only "
                        "(add its MIME type in cmake/viewer_page.cmake)")
  endif()
  if(NOT file MATCHES "^[A-Za-z0-9_./-]+$")
    message(FATAL_ERROR "src/penumbra/viewer/page/${file}: a served file's path takes letters, digits, '_', '-', '.' and '/' only")
  endif()
  file(READ ${PENUMBRA_PAGE_DIR}/${file} content)
  string(FIND "${content}" ")${PENUMBRA_PAGE_DELIMITER}\"" at)
  if(NOT at EQUAL -1)
    message(FATAL_ERROR "src/penumbra/viewer/page/${file} contains )${PENUMBRA_PAGE_DELIMITER}\", which ends the raw string "
                        "literal it is compiled in as: reword it, or change PENUMBRA_PAGE_DELIMITER in cmake/viewer_page.cmake")
  endif()
  if(file STREQUAL "index.html")
    set(path "/")
  else()
    set(path "/${file}")
  endif()
  string(APPEND PENUMBRA_VIEWER_PAGE_FILES
         "    {\"${path}\", \"${type}\",\n     R\"${PENUMBRA_PAGE_DELIMITER}(${content})${PENUMBRA_PAGE_DELIMITER}\"},\n")
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${PENUMBRA_PAGE_DIR}/${file})
endforeach()
if(NOT "index.html" IN_LIST PENUMBRA_PAGE_FILES)
  message(FATAL_ERROR "src/penumbra/viewer/page/index.html is missing: the viewer serves it at /")
endif()
configure_file(${PROJECT_SOURCE_DIR}/src/penumbra/viewer/viewer_page.cpp.in ${PROJECT_BINARY_DIR}/generated/viewer_page.cpp @ONLY)
