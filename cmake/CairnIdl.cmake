# cairn_idl_library(<target> <file.idl>...)
#
# Runs fastddsgen (-cs: case-sensitive identifiers) on each IDL file at build time into the build tree and
# builds the generated sources into a static library. Generated code is never committed.
find_program(FASTDDSGEN fastddsgen REQUIRED)

function(cairn_idl_library target)
  set(out_dir "${CMAKE_CURRENT_BINARY_DIR}/generated")
  file(MAKE_DIRECTORY "${out_dir}")
  set(sources)
  foreach(idl ${ARGN})
    get_filename_component(abs "${idl}" ABSOLUTE)
    get_filename_component(stem "${idl}" NAME_WE)
    set(gen "${out_dir}/${stem}.cxx" "${out_dir}/${stem}.h" "${out_dir}/${stem}PubSubTypes.cxx"
            "${out_dir}/${stem}PubSubTypes.h")
    add_custom_command(
      OUTPUT ${gen}
      COMMAND ${FASTDDSGEN} -cs -replace -d "${out_dir}" "${abs}"
      DEPENDS "${abs}"
      COMMENT "fastddsgen ${stem}.idl"
      VERBATIM)
    list(APPEND sources ${gen})
  endforeach()
  add_library(${target} STATIC ${sources})
  target_include_directories(${target} PUBLIC "${out_dir}")
  target_link_libraries(${target} PUBLIC fastrtps fastcdr)
  set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE ON)
endfunction()
