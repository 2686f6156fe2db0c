# Warnings, sanitizers and ccache for every lidarfuse target.

find_program(LIDARFUSE_CCACHE ccache)
if(LIDARFUSE_CCACHE AND NOT CMAKE_CXX_COMPILER_LAUNCHER)
    set(CMAKE_C_COMPILER_LAUNCHER "${LIDARFUSE_CCACHE}")
    set(CMAKE_CXX_COMPILER_LAUNCHER "${LIDARFUSE_CCACHE}")
endif()

add_library(lidarfuse_warnings INTERFACE)
target_compile_options(lidarfuse_warnings INTERFACE
    $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wpedantic -Wshadow=local -Wnon-virtual-dtor>
    $<$<COMPILE_LANGUAGE:C>:-Wall -Wextra>)
# In a unity build a class of one file that holds a type of its own anonymous namespace
# (KdTree::Impl, say) looks to GCC like a header's class doing so; it is not.
if(LIDARFUSE_UNITY_BUILD OR LIDARFUSE_TEST_BUNDLES)
    target_compile_options(lidarfuse_warnings INTERFACE
        $<$<COMPILE_LANGUAGE:CXX>:-Wno-subobject-linkage>)
endif()
if(LIDARFUSE_WERROR)
    target_compile_options(lidarfuse_warnings INTERFACE -Werror)
endif()

if(LIDARFUSE_SANITIZE)
    add_compile_options(-fsanitize=${LIDARFUSE_SANITIZE} -fno-omit-frame-pointer
                        -fno-sanitize-recover=all)
    add_link_options(-fsanitize=${LIDARFUSE_SANITIZE})
endif()

# Adds one executable per source file, named after the file, linked to the given libraries.
function(lidarfuse_add_executables out_var)
    cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
    set(names)
    foreach(src ${ARG_SOURCES})
        get_filename_component(name "${src}" NAME_WE)
        add_executable(${name} "${src}")
        target_link_libraries(${name} PRIVATE ${ARG_LIBS} lidarfuse_warnings)
        list(APPEND names ${name})
    endforeach()
    set(${out_var} ${names} PARENT_SCOPE)
endfunction()
