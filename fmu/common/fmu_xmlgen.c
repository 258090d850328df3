/*
 * Build-time tool: print the modelDescription.xml of the model linked into this executable.
 * Usage: <model>_xmlgen [OUTPUT.xml]   (stdout when no file is given)
 */
#include <stdio.h>

#include "fmu_xml.h"

int main(int argc, char **argv)
{
    if (argc > 2) {
        fprintf(stderr, "usage: %s [OUTPUT.xml]\n", argv[0]);
        return 2;
    }
    FILE *f = argc == 2 ? fopen(argv[1], "w") : stdout;
    if (f == NULL) {
        perror(argv[1]);
        return 1;
    }
    int rc = fmu_write_xml(&FMU_MODEL, f);
    if (f != stdout && fclose(f) != 0) {
        perror(argv[1]);
        rc = 1;
    }
    return rc;
}
