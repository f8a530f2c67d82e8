/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp/sp.h - the whole public API of the portable core in one include, for
 * integrators: #include "sp/sp.h" with firmware/core/include and the
 * build's generated/include (sp/math/version.h) on the include path. The headers follow the core's layers, lowest first
 * (firmware/core/layers.txt); include one of them alone to depend on less.
 * Nothing in the core includes this header.
 */
#ifndef SP_SP_H
#define SP_SP_H

/* math */
#include "sp/math/fixed.h"
#include "sp/math/status.h"
#include "sp/math/version.h"
/* model */
#include "sp/model/dynamics.h"
#include "sp/model/frames.h"
#include "sp/model/kinematics.h"
#include "sp/model/lu6.h"
#include "sp/model/platform.h"
/* motion */
#include "sp/motion/limits.h"
#include "sp/motion/setpoint.h"
#include "sp/motion/stop.h"
#include "sp/motion/stream.h"
#include "sp/motion/trajectory.h"
/* estimation */
#include "sp/estimation/estimate.h"
#include "sp/estimation/friction.h"
#include "sp/estimation/ftsensor.h"
#include "sp/estimation/motion_error.h"
#include "sp/estimation/wrench.h"
/* force */
#include "sp/force/admittance.h"
#include "sp/force/force.h"
/* control */
#include "sp/control/controller.h"
#include "sp/control/types.h"
/* link */
#include "sp/link/auth.h"
#include "sp/link/can.h"
#include "sp/link/e2e.h"
#include "sp/link/node.h"
#include "sp/link/port.h"
#include "sp/link/protocol.h"
/* canopen */
#include "sp/canopen/canopen.h"
#include "sp/canopen/canopen_link.h"
#include "sp/canopen/canopen_master.h"

#endif /* SP_SP_H */
