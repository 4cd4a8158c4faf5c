# pmg_add_library(<name> SOURCES ... [PUBLIC deps...] [PRIVATE deps...])
# One library folder = one target pmg_<name>, alias pmg::<name>, headers under <folder>/include,
# installed and exported in pmgkitTargets.
function(pmg_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC;PRIVATE" ${ARGN})
  add_library(pmg_${name} ${ARG_SOURCES})
  add_library(pmg::${name} ALIAS pmg_${name})
  set_target_properties(pmg_${name} PROPERTIES EXPORT_NAME ${name} OUTPUT_NAME pmg_${name})
  target_include_directories(pmg_${name} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(pmg_${name} PUBLIC ${ARG_PUBLIC} PRIVATE ${ARG_PRIVATE})
  target_compile_features(pmg_${name} PUBLIC cxx_std_17)
  install(TARGETS pmg_${name} EXPORT pmgkitTargets
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  install(DIRECTORY include/pmg DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endfunction()
