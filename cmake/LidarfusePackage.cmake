# The Debian package, lidarfuse_<version>_<arch>.deb (scripts/package.sh runs cpack):
# both executables, the systemd unit (not enabled, not started: the station needs its
# /etc/lidarfuse/station.yaml first), the UDP buffer sysctl drop-in, and the example
# config, schema and DDS settings under /usr/share/lidarfuse. Depends come from the
# executables' shared libraries (dpkg-shlibdeps). No maintainer scripts.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME lidarfuse)
set(CPACK_PACKAGE_VERSION "${PROJECT_VERSION}")
set(CPACK_PACKAGE_CONTACT "lidarfuse maintainers <maintainers@users.noreply.h-seed-26ab0d55.example>")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_RELEASE "")
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "real-time fusion of several Ouster LiDARs with unknown poses")
# The long description; CPack puts the summary above it and indents it.
set(CPACK_DEBIAN_PACKAGE_DESCRIPTION
    "lidarfused fuses the point clouds of 2-8 Ouster LiDARs on a roadside measuring
station into one cloud per frame. It finds every sensor's pose without a
calibration target and keeps tracking it while the poles sway, and publishes
the clouds, poses, tf and diagnostics on DDS in ROS 2's mapping. The lidarfuse
command simulates stations, calibrates, fuses and evaluates recorded captures.")

# Every Debian package carries its copyright file and a compressed changelog (changelog.gz:
# a native package, its version has no Debian revision).
set(_lidarfuse_doc "${CMAKE_INSTALL_DATAROOTDIR}/doc/lidarfuse")
install(FILES "${PROJECT_SOURCE_DIR}/packaging/copyright" DESTINATION "${_lidarfuse_doc}")
# gzip -9n: maximum compression and no name or time stamp inside (reproducible).
file(MAKE_DIRECTORY "${PROJECT_BINARY_DIR}/packaging")
execute_process(COMMAND gzip -9n -c "${PROJECT_SOURCE_DIR}/packaging/changelog"
                OUTPUT_FILE "${PROJECT_BINARY_DIR}/packaging/changelog.gz"
                RESULT_VARIABLE _lidarfuse_gzip)
if(NOT _lidarfuse_gzip EQUAL 0)
    message(FATAL_ERROR "gzip of packaging/changelog failed: ${_lidarfuse_gzip}")
endif()
install(FILES "${PROJECT_BINARY_DIR}/packaging/changelog.gz" DESTINATION "${_lidarfuse_doc}")
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS "${PROJECT_SOURCE_DIR}/packaging/changelog")
include(CPack)
