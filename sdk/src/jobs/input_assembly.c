// The input assembly job: X_c exactly as docs/inputs.md lays it out —
//     [ Z_t | v_t, v_{t−1} | 6D rotations × 3 frames | heading-frame joint positions × 3 frames | β | material ]
// frames[0..2] are t+1, t, t−1 (the pose passed to Step is t+1).
#include "jobs.h"

#include <math.h>

#define PLEAT_PI 3.14159265358979323846

static double plWrapAngle( double a )
{
	// to (−π, π]
	while ( a > PLEAT_PI )
	{
		a -= 2.0 * PLEAT_PI;
	}
	while ( a <= -PLEAT_PI )
	{
		a += 2.0 * PLEAT_PI;
	}
	return a;
}

// yaw⁻¹ · v for a rotation about +Y by yaw.
static void plUnyaw( double yaw, const double v[3], double out[3] )
{
	double c = cos( yaw ), s = sin( yaw );
	out[0] = c * v[0] - s * v[2];
	out[1] = v[1];
	out[2] = s * v[0] + c * v[2];
}

// 6D of a row-major 3×3: the first two columns, column by column.
static float* plWrite6d( float* x, const double m[9] )
{
	*x++ = (float)m[0];
	*x++ = (float)m[3];
	*x++ = (float)m[6];
	*x++ = (float)m[1];
	*x++ = (float)m[4];
	*x++ = (float)m[7];
	return x;
}

uint64_t plInputCountFormula( uint64_t latent_count, uint64_t input_joint_count, uint64_t beta_count )
{
	// Z_t, two root velocities (v, ω) × (t+1, t), 6D rotations of Jin joints + pelvis tilt × 3 frames, heading-frame
	// positions of Jin joints × 3 frames, β, material.
	return latent_count + 8u + 3u * ( 6u * input_joint_count + 6u ) + 9u * input_joint_count + beta_count + 4u;
}

int plInputAssemblyJob_Validate( const plInputAssemblyJob* job )
{
	if ( job == NULL || job->frames[0] == NULL || job->frames[1] == NULL || job->frames[2] == NULL ||
		 ( job->latent == NULL && job->latent_count > 0 ) || ( job->beta == NULL && job->beta_count > 0 ) ||
		 ( job->input_joints == NULL && job->input_joint_count > 0 ) || job->material_normalized == NULL ||
		 job->input_joint_count >= PLEAT_MAX_JOINTS )
	{
		return 0;
	}
	for ( uint32_t i = 0; i < job->input_joint_count; ++i )
	{
		if ( job->input_joints[i] >= PLEAT_MAX_JOINTS )
		{
			return 0;
		}
	}
	uint64_t count = plInputCountFormula( job->latent_count, job->input_joint_count, job->beta_count );
	return count <= UINT32_MAX && job->output.stride_bytes == 4 && PLEAT_SPAN_HOLDS( job->output, 4, (uint32_t)count );
}

plResult plInputAssemblyJob_Run( const plInputAssemblyJob* job )
{
	if ( !plInputAssemblyJob_Validate( job ) )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	float* x = (float*)job->output.ptr;
	const plPoseFrame* f1 = job->frames[0]; // t+1
	const plPoseFrame* f0 = job->frames[1]; // t
	const plPoseFrame* fm = job->frames[2]; // t−1

	for ( uint32_t i = 0; i < job->latent_count; ++i )
	{
		*x++ = job->latent[i];
	}
	// Root velocities, linear parts in the heading frame of t+1.
	double d[3], v[3];
	for ( int a = 0; a < 3; ++a )
	{
		d[a] = ( f1->joint_positions[0][a] - f0->joint_positions[0][a] ) / f1->dt_s;
	}
	plUnyaw( f1->yaw, d, v );
	*x++ = (float)v[0];
	*x++ = (float)v[1];
	*x++ = (float)v[2];
	*x++ = (float)( plWrapAngle( f1->yaw - f0->yaw ) / f1->dt_s );
	for ( int a = 0; a < 3; ++a )
	{
		d[a] = ( f0->joint_positions[0][a] - fm->joint_positions[0][a] ) / f0->dt_s;
	}
	plUnyaw( f1->yaw, d, v );
	*x++ = (float)v[0];
	*x++ = (float)v[1];
	*x++ = (float)v[2];
	*x++ = (float)( plWrapAngle( f0->yaw - fm->yaw ) / f0->dt_s );

	// Rotations: per frame, each input joint's local R_k, then the pelvis tilt yaw⁻¹ · P.
	for ( int fi = 0; fi < 3; ++fi )
	{
		const plPoseFrame* f = job->frames[fi];
		for ( uint32_t i = 0; i < job->input_joint_count; ++i )
		{
			x = plWrite6d( x, f->local_rotations[job->input_joints[i]] );
		}
		double c = cos( f->yaw ), s = sin( f->yaw );
		// Ry(−yaw) = [[c, 0, −s], [0, 1, 0], [s, 0, c]]
		double unyaw[9] = { c, 0.0, -s, 0.0, 1.0, 0.0, s, 0.0, c };
		double tilt[9];
		for ( int r = 0; r < 3; ++r )
		{
			for ( int col = 0; col < 3; ++col )
			{
				tilt[r * 3 + col] = unyaw[r * 3 + 0] * f->pelvis_rotation[0 * 3 + col] +
									unyaw[r * 3 + 1] * f->pelvis_rotation[1 * 3 + col] +
									unyaw[r * 3 + 2] * f->pelvis_rotation[2 * 3 + col];
			}
		}
		x = plWrite6d( x, tilt );
	}
	// Positions: per frame, H_f⁻¹ p_k = yaw_f⁻¹ (p_k − p_0).
	for ( int fi = 0; fi < 3; ++fi )
	{
		const plPoseFrame* f = job->frames[fi];
		for ( uint32_t i = 0; i < job->input_joint_count; ++i )
		{
			const double* p = f->joint_positions[job->input_joints[i]];
			double rel[3] = { p[0] - f->joint_positions[0][0], p[1] - f->joint_positions[0][1],
							  p[2] - f->joint_positions[0][2] };
			plUnyaw( f->yaw, rel, v );
			*x++ = (float)v[0];
			*x++ = (float)v[1];
			*x++ = (float)v[2];
		}
	}
	for ( uint32_t b = 0; b < job->beta_count; ++b )
	{
		*x++ = job->beta[b];
	}
	for ( int m = 0; m < 4; ++m )
	{
		*x++ = job->material_normalized[m];
	}
	return PLEAT_RESULT_OK;
}
