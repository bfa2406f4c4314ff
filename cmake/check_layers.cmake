# The layers of src/penumbra (docs/ARCHITECTURE.md "Layers"): a folder may include itself and the folders
# of the layers below it, never a folder of its own layer (the technique folders are one layer: no
# technique includes another) nor one above. Run as `cmake -DSOURCE_DIR=<repo> -P check_layers.cmake`;
# the build runs it whenever a source changes (target penumbra_layers) and ctest runs it as `layers`.
# A new folder goes into this table, or the check fails naming it.
set(PENUMBRA_LAYERS
  "core"                          # math, colour, images, random numbers, parallel loops, errors
  "data"                          # volumes, transfer functions, particles, the file readers
  "accel"                         # macrocells, the extinction SAT, the light cache, brick reductions
  "scene"                         # the scene model: camera, lights, objects, settings
  "geometry"                      # exact ray queries: sphere BVH, isosurface ray caster
  "lighting"                      # what a light sees (ShadowCasters) and the technique interfaces
  "shadows particles isosurface"   # the techniques, one folder per paper family
  "registry"                      # every technique by name: the catalogue and the factory
  "scene_io"                      # the scene-file reader, scenes for data files, demo scenes
  "render"                        # the frame: prepared volumes, surfaces, ray caster, Renderer
  "engine distributed"             # edits and progressive frames; MPI ranks and compositing
  "viewer")                       # the browser viewer's server

if(NOT SOURCE_DIR)
  message(FATAL_ERROR "check_layers.cmake: pass -DSOURCE_DIR=<the repository root>")
endif()

set(rank 0)
foreach(layer IN LISTS PENUMBRA_LAYERS)
  set(folders "${layer}")
  separate_arguments(folders)
  foreach(folder IN LISTS folders)
    set(rank_of_${folder} ${rank})
  endforeach()
  math(EXPR rank "${rank} + 1")
endforeach()

file(GLOB_RECURSE files RELATIVE ${SOURCE_DIR}/src/penumbra ${SOURCE_DIR}/src/penumbra/*.h ${SOURCE_DIR}/src/penumbra/*.cpp)
set(violations "")
foreach(file IN LISTS files)
  string(REGEX MATCH "^[^/]+" folder "${file}")
  if(NOT DEFINED rank_of_${folder})
    string(APPEND violations "\n  src/penumbra/${file}: folder '${folder}' is in no layer (add it to cmake/check_layers.cmake)")
    continue()
  endif()
  file(STRINGS ${SOURCE_DIR}/src/penumbra/${file} includes REGEX "^#include \"penumbra/[a-z_]+/")
  foreach(line IN LISTS includes)
    string(REGEX REPLACE "^#include \"penumbra/([a-z_]+)/.*$" "\\1" target "${line}")
    if(target STREQUAL folder)
      continue()
    endif()
    if(NOT DEFINED rank_of_${target})
      string(APPEND violations "\n  src/penumbra/${file}: includes '${target}/', a folder in no layer")
    elseif(NOT rank_of_${target} LESS rank_of_${folder})
      string(REGEX REPLACE "^#include \"(.*)\".*$" "\\1" header "${line}")
      if(rank_of_${target} EQUAL rank_of_${folder})
        set(why "a sibling in the same layer")
      else()
        set(why "a layer above '${folder}/'")
      endif()
      string(APPEND violations "\n  src/penumbra/${file}: includes ${header} (${why})")
    endif()
  endforeach()
endforeach()

if(violations)
  message(FATAL_ERROR "includes across the layers of docs/ARCHITECTURE.md:${violations}")
endif()
list(LENGTH files count)
message(STATUS "layers: ${count} files of src/penumbra include only their own folder and the layers below")
