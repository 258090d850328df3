/**
 * @file rrr.h
 * @brief Umbrella header of librrr, the closed-form model of the RRR arm.
 */
#ifndef RRR_H
#define RRR_H
#include "rrr_status.h"
#include "rrr_model.h"
#include "rrr_params.h"
#include "rrr_kinematics.h"
#include "rrr_dynamics.h"
#include "rrr_actuator.h"
#include "rrr_control.h"
#include "rrr_plant.h"
#include "rrr_sim.h"
#include "rrr_derivatives.h"
#include "rrr_batch.h"
#include "rrr_version.h"
#endif /* RRR_H */
