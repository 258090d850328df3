/**
 * @file fmu_xml.h
 * @brief Print the files of an FMU archive that describe a model, from its variable table:
 *        modelDescription.xml (FMI 2.0 or 3.0), sources/buildDescription.xml (FMI 3.0) and
 *        documentation/index.html. A build-time tool (fmu_xmlgen.c), never part of a binary.
 */
#ifndef FMU_XML_H
#define FMU_XML_H

#include <stdio.h>

#include "fmu_model.h"

/** @brief The source files of the FMU (compile units, names relative to sources/). */
typedef struct fmu_sources {
    const char *const *files;         ///< file names
    size_t n;                         ///< number of files (0: no sources in the archive)
} fmu_sources;

/**
 * @brief Write the modelDescription.xml of m for FMI version 2 or 3 to f: both interface types
 *        (Model Exchange and Co-Simulation), units, log categories, default experiment, every
 *        variable (start = the value after set_defaults), continuous states, model structure;
 *        FMI 2 lists the sources in <SourceFiles>.
 * @return 0 on success, 1 on a broken table or a write error (message on stderr)
 */
int fmu_write_xml(const fmu_model *m, int fmi_version, fmu_sources src, FILE *f);

/** @brief Write the FMI 3.0 sources/buildDescription.xml (one configuration, the sources). */
int fmu_write_build_description(const fmu_model *m, fmu_sources src, FILE *f);

/**
 * @brief Write documentation/index.html: what the FMU computes (equations_html, a fragment; NULL:
 *        a pointer to the FMU's section of the manual), every
 *        variable with unit, causality, variability, default and description, the interfaces and
 *        states, the conventions (conventions_html, a fragment) and how to build from sources;
 *        platforms: the binaries/ folders of this build's archive, comma-separated (the build
 *        passes what it packs, so the page lists exactly the binaries the archive holds).
 */
int fmu_write_doc(const fmu_model *m, int fmi_version, const char *equations_html,
                  const char *conventions_html, const char *platforms, FILE *f);

/** @brief Write terminalsAndIcons/terminalsAndIcons.xml of a model with a CAN terminal
 *         (fmu_bus.h): one network terminal (org.fmi-ls-bus.network-terminal, matching rule
 *         org.fmi-ls-bus.transceiver) with its four member variables. 1 without a terminal. */
int fmu_write_terminals(const fmu_model *m, FILE *f);

/** @brief Write extra/org.fmi-standard.fmi-ls-bus/fmi-ls-manifest.xml (FMI-LS-BUS 1.0.0, a
 *         network FMU: isBusSimulationFMU="false"). 1 without a terminal. */
int fmu_write_lsbus_manifest(const fmu_model *m, FILE *f);

#endif /* FMU_XML_H */
