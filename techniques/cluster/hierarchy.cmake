# The view-sample cluster hierarchy as a reusable module (contract: helpers/hierarchy_contract.md).
#   include(${CMAKE_SOURCE_DIR}/techniques/cluster/hierarchy.cmake)
#   pb_add_cluster_hierarchy(technique_<name>)
# adds hierarchy.cpp to the target, this folder to its include path (#include "hierarchy.h"), and embeds
# the build shaders as the generated header hierarchy_spv.h (k<stem>_spv arrays), which each module
# generates for itself under the same name, so hierarchy.cpp compiles unchanged into every module.
set(PB_CLUSTER_HIERARCHY_DIR ${CMAKE_CURRENT_LIST_DIR})
function(pb_add_cluster_hierarchy target)
  set(dir ${PB_CLUSTER_HIERARCHY_DIR})
  target_sources(${target} PRIVATE ${dir}/hierarchy.cpp)
  target_include_directories(${target} PRIVATE ${dir})
  pb_embed_shaders(TARGET ${target} HEADER hierarchy_spv.h SHADERS
    ${dir}/shaders/hierarchy_depth_range.comp ${dir}/shaders/hierarchy_occupancy.comp ${dir}/shaders/hierarchy_leaf_alloc.comp
    ${dir}/shaders/hierarchy_leaf_bounds.comp ${dir}/shaders/hierarchy_leaf_finalize.comp
    ${dir}/shaders/hierarchy_leaf_cones.comp ${dir}/shaders/hierarchy_propagate.comp)
endfunction()
