/**
 * @file rrr.h
 * @brief Umbrella header of librrr, the closed-form model of the RRR arm.
 */
#ifndef RRR_H
#define RRR_H
#include "rrr/rrr_status.h"
#include "rrr/rrr_model.h"
#include "rrr/rrr_kinematics.h"
#include "rrr/rrr_dynamics.h"
#include "rrr/rrr_actuator.h"
#include "rrr/rrr_control.h"
#include "rrr/rrr_plant.h"

/** Version of librrr. */
#define RRR_VERSION_STRING "0.1.0"
#endif /* RRR_H */
