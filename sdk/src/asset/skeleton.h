// Internal: the rest pose as the public plRestJoint array (pleat.h, "Skeleton and rest pose"), shared by the asset
// (β = 0) and the instance (its current β).
#ifndef PLEAT_SKELETON_H
#define PLEAT_SKELETON_H
#include "pleat/pleat.h"

#include <stdint.h>

// Writes joint_count entries: parents as given, positions [J][3] (metres), local translations J_k − J_parent taken
// in double before rounding (so a child's translation is exact even where the two positions round differently), and
// identity local rotations.
void plFillRestPose( const int32_t* parents, const double* positions, uint32_t joint_count, plRestJoint* out_joints );

#endif
