# Warnings and sanitizers for our own targets only (never for third-party code).
add_library(seavio_warnings INTERFACE)
target_compile_options(seavio_warnings INTERFACE -Wall -Wextra -Werror)
# Unity builds (-DCMAKE_UNITY_BUILD=ON, what CI's scripts use to cut compile time) #include
# each .cpp into one unity source, so GCC sees a .cpp's anonymous-namespace types as coming
# from a header and warns on every class that holds one (-Wsubobject-linkage); that is only
# true of real headers, which a non-unity build still checks.
if(CMAKE_UNITY_BUILD AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
  target_compile_options(seavio_warnings INTERFACE -Wno-subobject-linkage)
endif()
if(SEAVIO_SANITIZE STREQUAL "address")
  target_compile_options(seavio_warnings INTERFACE -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  target_link_options(seavio_warnings INTERFACE -fsanitize=address,undefined)
elseif(SEAVIO_SANITIZE STREQUAL "thread")
  target_compile_options(seavio_warnings INTERFACE -fsanitize=thread -fno-omit-frame-pointer)
  target_link_options(seavio_warnings INTERFACE -fsanitize=thread)
elseif(NOT SEAVIO_SANITIZE STREQUAL "")
  message(FATAL_ERROR "SEAVIO_SANITIZE must be '', 'address' or 'thread'")
endif()

# ASan's use-after-scope check poisons and unpoisons the shadow of every stack variable at each
# scope's entry and exit. The pose solvers evaluate small fixed-size Eigen expressions per point
# per iteration, with hundreds of stack temporaries per call, so the check made them ~25x slower
# than Release and made their end-to-end tests the ASan phase's
# long pole. In these Eigen-heavy modules only, it is off: 3x faster there, all other ASan and
# UBSan checks (heap, stack and global overflows, use after free, leaks, undefined behaviour)
# stay on; every other target (features, camera, drivers, daemon, tools, tests) keeps it.
# docs/reliability.md, "CI phase times".
set(SEAVIO_ASAN_NO_SCOPE_MODULES geometry odometry imu icp map matching)

# seavio_module(<name> [DEPS ...]): library seavio_<name> from every .cpp in the calling
# folder, alias seavio::<name>. Headers are included as "core/<area>/<file>.hpp" from the
# repository root. A folder with no .cpp yields a header-only INTERFACE library.
function(seavio_module name)
  cmake_parse_arguments(ARG "" "" "DEPS" ${ARGN})
  file(GLOB srcs CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.cpp)
  if(srcs)
    add_library(seavio_${name} STATIC ${srcs})
    target_include_directories(seavio_${name} PUBLIC ${PROJECT_SOURCE_DIR} ${PROJECT_BINARY_DIR}/generated)
    target_link_libraries(seavio_${name} PUBLIC ${ARG_DEPS} PRIVATE seavio_warnings)
    set_target_properties(seavio_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
    if(SEAVIO_SANITIZE STREQUAL "address" AND name IN_LIST SEAVIO_ASAN_NO_SCOPE_MODULES)
      target_compile_options(seavio_${name} PRIVATE -fno-sanitize-address-use-after-scope)
    endif()
  else()
    add_library(seavio_${name} INTERFACE)
    target_include_directories(seavio_${name} INTERFACE ${PROJECT_SOURCE_DIR} ${PROJECT_BINARY_DIR}/generated)
    target_link_libraries(seavio_${name} INTERFACE ${ARG_DEPS})
  endif()
  add_library(seavio::${name} ALIAS seavio_${name})
endfunction()

# seavio_test(<name> LIBS ...): one gtest executable from every .cpp in the calling folder.
# Unity builds put up to 8 of those files in one translation unit, so a test file keeps its
# helpers in `namespace <file stem> { namespace { ... } }`: the files of one folder reuse helper
# names (kSpeed, tempPath, RecordingProcessor, ...), which a bare anonymous namespace would clash on.
function(seavio_test name)
  cmake_parse_arguments(ARG "" "" "LIBS" ${ARGN})
  file(GLOB srcs CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.cpp)
  if(NOT srcs)
    return()
  endif()
  add_executable(test_${name} ${srcs})
  target_link_libraries(test_${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main GTest::gmock seavio_warnings)
  target_compile_definitions(test_${name} PRIVATE SEAVIO_SOURCE_DIR="${PROJECT_SOURCE_DIR}" SEAVIO_BINARY_DIR="${PROJECT_BINARY_DIR}")
  gtest_discover_tests(test_${name} DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT 600)
endfunction()
