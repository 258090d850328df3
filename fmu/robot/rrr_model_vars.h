/**
 * @file rrr_model_vars.h
 * @brief Variable-table rows of the rrr_model parameters, shared by the plant and the controller
 *        so both FMUs name, describe and unit them identically: expanded from librrr's one
 *        parameter table (RRR_MODEL_PARAMS in rrr/rrr_params.h). The robot's rows live here,
 *        beside the models that use them (fmu/plant, fmu/controller); fmu/common is the FMI glue
 *        and knows no robot.
 *
 * RRR_MODEL_VARS(T, M, B) expands to RRR_MV_COUNT rows for the rrr_model at member path M of the
 * model data type T, with value references B, B + 1, ... in the table's order. Rows are fixed
 * parameters, start = rrr_model_default(); the description ends with the valid range.
 */
#ifndef RRR_MODEL_VARS_H
#define RRR_MODEL_VARS_H

#include "fmu_model.h"
#include "rrr/rrr_params.h"

#include <stddef.h>

/** Number of rows (value references B .. B + RRR_MV_COUNT - 1). */
#define RRR_MV_COUNT RRR_N_PARAMS

/* The valid range as the end of a description. */
#define RRR_MV_RANGE_RRR_PARAM_ANY ""
#define RRR_MV_RANGE_RRR_PARAM_NONNEG ", >= 0"
#define RRR_MV_RANGE_RRR_PARAM_POS ", > 0"

/**
 * The RRR_MV_COUNT rows of the model parameters, in a model's table. The model defines T (its
 * data type, whose rrr_model member is called `model`) and RRR_MV_BASE (the value reference of
 * the first row). rrr_model holds its parameters as RRR_N_PARAMS doubles in the table's order
 * (tests/c/test_model.c checks it), so a row's value reference is RRR_MV_BASE plus its offset
 * in doubles; fmu_model_check proves at instantiation that each equals the row index.
 */
#define RRR_MV_ROW(NAME, MEMBER, UNIT, BOUND, DESC)                                           \
    FMU_PARAM(RRR_MV_BASE + (fmu_vr)(offsetof(rrr_model, MEMBER) / sizeof(double)), NAME,     \
              DESC RRR_MV_RANGE_##BOUND, UNIT, T, model.MEMBER),
#define RRR_MODEL_VARS RRR_MODEL_PARAMS(RRR_MV_ROW)

/** Byte offset in rrr_model of the model parameter with value reference vr, when the model's
 *  rows start at value reference base; (size_t)-1 when vr is not one of them. */
static inline size_t rrr_mv_offset(fmu_vr vr, fmu_vr base)
{
    return vr - base < (fmu_vr)RRR_MV_COUNT ? (size_t)(vr - base) * sizeof(double) : (size_t)-1;
}

/** 1 when byte offset OFF (rrr_mv_offset) lies in member MEMBER of rrr_model (unsigned
 *  wrap-around: OFF - first < size  <=>  first <= OFF < first + size). */
#define RRR_MV_IN(OFF, MEMBER)                                                                \
    ((size_t)(OFF) - offsetof(rrr_model, MEMBER) < sizeof(((rrr_model *)0)->MEMBER))

/** The joint (0, 1, 2) of byte offset OFF in a per-joint member (kt, b: 3 doubles; f, w:
 *  3 x RRR_NF doubles) of rrr_model. */
#define RRR_MV_JOINT(OFF, MEMBER)                                                             \
    (int)(((OFF) - offsetof(rrr_model, MEMBER)) / (sizeof(((rrr_model *)0)->MEMBER) / RRR_NJ))

#endif /* RRR_MODEL_VARS_H */
