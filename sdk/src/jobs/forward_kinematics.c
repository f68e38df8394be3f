// Forward kinematics for one frame (docs/inputs.md "Skeleton and forward kinematics"), in double precision:
//     G_0 = T(t_root) · Rot(Q_root) · T(J_0) · Rot(R_0),  G_k = G_parent(k) · T(J_k − J_parent(k)) · Rot(R_k)
//     M_k = G_k · T(−J_k)    (skinning matrix, rest space → output space)
// plus the heading yaw of the pelvis rotation P = Q_root · R_0.
#include "jobs.h"

#include <math.h>

void plQuatToMatrix( const double q[4], double m[9] )
{
	double x = q[0], y = q[1], z = q[2], w = q[3];
	m[0] = 1 - 2 * ( y * y + z * z );
	m[1] = 2 * ( x * y - z * w );
	m[2] = 2 * ( x * z + y * w );
	m[3] = 2 * ( x * y + z * w );
	m[4] = 1 - 2 * ( x * x + z * z );
	m[5] = 2 * ( y * z - x * w );
	m[6] = 2 * ( x * z - y * w );
	m[7] = 2 * ( y * z + x * w );
	m[8] = 1 - 2 * ( x * x + y * y );
}

static void plMul33( const double a[9], const double b[9], double out[9] )
{
	for ( int r = 0; r < 3; ++r )
	{
		for ( int c = 0; c < 3; ++c )
		{
			out[r * 3 + c] = a[r * 3 + 0] * b[0 * 3 + c] + a[r * 3 + 1] * b[1 * 3 + c] + a[r * 3 + 2] * b[2 * 3 + c];
		}
	}
}

static void plMul33v( const double a[9], const double v[3], double out[3] )
{
	for ( int r = 0; r < 3; ++r )
	{
		out[r] = a[r * 3 + 0] * v[0] + a[r * 3 + 1] * v[1] + a[r * 3 + 2] * v[2];
	}
}

int plForwardKinematicsJob_Validate( const plForwardKinematicsJob* job )
{
	if ( job == NULL || job->parents == NULL || job->joint_count == 0 || job->joint_count > PLEAT_MAX_JOINTS ||
		 job->rest_joints == NULL || job->root_translation == NULL || job->root_rotation == NULL || job->frame == NULL ||
		 job->parents[0] != -1 )
	{
		return 0;
	}
	for ( uint32_t k = 1; k < job->joint_count; ++k )
	{
		if ( job->parents[k] < 0 || job->parents[k] >= (int32_t)k )
		{
			return 0;
		}
	}
	return 1;
}

plResult plForwardKinematicsJob_Run( const plForwardKinematicsJob* job )
{
	if ( !plForwardKinematicsJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	plPoseFrame* f = job->frame;
	double global_rotations[PLEAT_MAX_JOINTS][9];
	const double* J = job->rest_joints;
	for ( uint32_t k = 0; k < job->joint_count; ++k )
	{
		double offset[3], rotated[3];
		const double* parent_rotation;
		const double* parent_position;
		if ( k == 0 )
		{
			parent_rotation = job->root_rotation;
			parent_position = job->root_translation;
			offset[0] = J[0];
			offset[1] = J[1];
			offset[2] = J[2];
		}
		else
		{
			int32_t p = job->parents[k];
			parent_rotation = global_rotations[p];
			parent_position = f->joint_positions[p];
			offset[0] = J[k * 3 + 0] - J[p * 3 + 0];
			offset[1] = J[k * 3 + 1] - J[p * 3 + 1];
			offset[2] = J[k * 3 + 2] - J[p * 3 + 2];
		}
		plMul33v( parent_rotation, offset, rotated );
		f->joint_positions[k][0] = parent_position[0] + rotated[0];
		f->joint_positions[k][1] = parent_position[1] + rotated[1];
		f->joint_positions[k][2] = parent_position[2] + rotated[2];
		plMul33( parent_rotation, f->local_rotations[k], global_rotations[k] );
	}
	for ( int e = 0; e < 9; ++e )
	{
		f->pelvis_rotation[e] = global_rotations[0][e];
	}
	// Heading: yaw about +Y taking +Z to the XZ projection of P·(0, 0, 1) = P's third column.
	double fx = f->pelvis_rotation[2], fz = f->pelvis_rotation[8];
	f->yaw = sqrt( fx * fx + fz * fz ) < 1e-6 ? job->previous_yaw : atan2( fx, fz );
	f->dt_s = job->dt_s;
	if ( job->skin_matrices != NULL )
	{
		for ( uint32_t k = 0; k < job->joint_count; ++k )
		{
			double t[3];
			plMul33v( global_rotations[k], &J[k * 3], t );
			float* m = job->skin_matrices + (size_t)k * 12;
			for ( int r = 0; r < 3; ++r )
			{
				m[r * 4 + 0] = (float)global_rotations[k][r * 3 + 0];
				m[r * 4 + 1] = (float)global_rotations[k][r * 3 + 1];
				m[r * 4 + 2] = (float)global_rotations[k][r * 3 + 2];
				m[r * 4 + 3] = (float)( f->joint_positions[k][r] - t[r] );
			}
		}
	}
	return PLEAT_RESULT_OK;
}
