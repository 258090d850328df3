/**
 * @file fmu_xml.h
 * @brief Print the FMI 2.0 modelDescription.xml of a model from its variable table.
 */
#ifndef FMU_XML_H
#define FMU_XML_H

#include <stdio.h>

#include "fmu_model.h"

/**
 * @brief Write the modelDescription.xml of m to f: GUID, units, log categories, default
 *        experiment, every variable (start = the value after set_defaults), model structure.
 * @return 0 on success, 1 on a broken table or a write error (message on stderr)
 */
int fmu_write_xml(const fmu_model *m, FILE *f);

#endif /* FMU_XML_H */
