/* libFuzzer target: arbitrary bytes as modelDescription.xml through the importer's scanner
 * (rrr_fmi_md_parse, then lookups by name and value reference and every variable's start,
 * derivative and nominal). Any input must parse or be refused with a message; never a read
 * outside the buffer (ASan), never undefined behaviour (UBSan). Also linked into the CTest
 * test_fmi_import, which calls rrr_fuzz_fmi_import_one on hostile inputs. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rrr_fmi_import.h"

int rrr_fuzz_fmi_import_one(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* 0: parsed, 1: refused with a message; 2: refused without one (a defect). */
int rrr_fuzz_fmi_import_one(const uint8_t *data, size_t size)
{
    char *text = malloc(size + 1);
    if (text == NULL) {
        return 1;
    }
    if (size > 0) {
        memcpy(text, data, size);
    }
    text[size] = '\0';
    rrr_fmi_md md;
    char err[256] = "";
    if (rrr_fmi_md_parse(&md, text, size, err, sizeof err) != 0) { /* frees text */
        return err[0] != '\0' ? 1 : 2;
    }
    char buf[64];
    unsigned long vr = 0;
    for (size_t i = 0; i < md.nvars; ++i) {
        const rrr_fmi_var *v = &md.vars[i];
        (void)rrr_fmi_var_attr(v, "start", buf, sizeof buf);
        (void)rrr_fmi_var_attr(v, "derivative", buf, sizeof buf);
        (void)rrr_fmi_var_attr(v, "nominal", buf, 4);
        if (rrr_fmi_md_var(&md, v->name) == NULL ||
            rrr_fmi_md_var_by_vr(&md, v->vr, NULL) == NULL ||
            rrr_fmi_md_vr(&md, v->name, NULL, &vr, err, sizeof err) != 0) {
            abort(); /* an indexed variable must be found again */
        }
    }
    (void)rrr_fmi_md_start(&md, "q[1]", buf, sizeof buf);
    rrr_fmi_md_free(&md);
    return 0;
}

#ifndef RRR_FUZZ_NO_MAIN
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (rrr_fuzz_fmi_import_one(data, size) == 2) {
        abort(); /* refused without saying why */
    }
    return 0;
}
#endif
