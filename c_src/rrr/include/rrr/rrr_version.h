/**
 * @file rrr_version.h
 * @brief The version of the toolkit, in one place.
 *
 * Every other version is read from this file: CMake's project(VERSION) (CMakeLists.txt), the
 * Python package's metadata and ``rrr_robot.__version__`` (pyproject.toml, a regex), the FMUs'
 * ``version`` and ``generationTool`` (fmu/common/fmu_xml.c) and the manual's release
 * (docs/conf.py). tests/python/unit/test_version.py checks that they agree.
 */
#ifndef RRR_VERSION_H
#define RRR_VERSION_H

#include "rrr_status.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Major version: incompatible changes of the C API or ABI (the SONAME is librrr.so.MAJOR). */
#define RRR_VERSION_MAJOR 0
/** Minor version: features added compatibly. */
#define RRR_VERSION_MINOR 1
/** Patch version: fixes only. */
#define RRR_VERSION_PATCH 0
/** The version as "MAJOR.MINOR.PATCH". */
#define RRR_VERSION_STRING "0.1.0"

/** @brief The version librrr was built as ("MAJOR.MINOR.PATCH"): RRR_VERSION_STRING of the
 *  library, which a program compares with the header's it was compiled against. */
RRR_API const char *rrr_version(void);

#ifdef __cplusplus
}
#endif
#endif /* RRR_VERSION_H */
