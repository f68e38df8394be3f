// The skeleton API (plAsset_GetRestPose, plInstance_GetRestPose) returns the asset's parents and J(β) exactly, and a
// retarget built through it from a T-pose engine skeleton (samples/minimal/retarget.c) dresses the shipped t-shirt
// exactly as feeding the same motion as rotations relative to the asset's A-pose, derived by hand.
//
//     test_skeleton_and_retarget [path/to/tshirt.pleat]   (the retarget tests skip without the shipped asset)
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "retarget.h"
#include "test_common.h"

#include <stdio.h>

#define PL_PI 3.14159265358979323846

static const char* s_shipped_asset_path;

// ---- the API against the asset's own arrays (test asset builder) ----

// A small branching skeleton (a pelvis with two legs and a spine) instead of the builder's chain, so that parents and
// local translations are not all "previous joint".
static plTestAsset* plBranchingModel( void )
{
	plTestAssetParams p = plTestAsset_DefaultParams();
	p.joint_count = 5;
	p.beta_count = 3;
	plTestAsset* model = plTestAsset_Create( &p );
	assert_non_null( model );
	static const int32_t parents[5] = { -1, 0, 0, 1, 2 };
	static const float positions[5][3] = {
		{ 0.0f, 0.1f, 0.0f }, { 0.12f, 0.0f, 0.0f }, { 0.0f, 0.3f, -0.02f }, { 0.14f, -0.4f, 0.02f }, { 0.0f, 0.5f, 0.0f },
	};
	memcpy( model->parents, parents, sizeof( parents ) );
	memcpy( model->joint_template, positions, sizeof( positions ) );
	return model;
}

static void plExpectRestPose( const plRestJoint* rest, const plTestAsset* model, const double* positions )
{
	for ( uint32_t k = 0; k < model->J; ++k )
	{
		int32_t parent = model->parents[k];
		assert_int_equal( rest[k].parent, parent );
		const float got[3] = { rest[k].position.x, rest[k].position.y, rest[k].position.z };
		const float local[3] = { rest[k].local_translation.x, rest[k].local_translation.y, rest[k].local_translation.z };
		for ( int c = 0; c < 3; ++c )
		{
			assert_float_equal( got[c], (float)positions[k * 3 + c], 0.0f );
			double expected_local = positions[k * 3 + c] - ( parent >= 0 ? positions[parent * 3 + c] : 0.0 );
			assert_float_equal( local[c], (float)expected_local, 0.0f );
		}
		assert_true( rest[k].local_rotation.x == 0.0f && rest[k].local_rotation.y == 0.0f &&
					 rest[k].local_rotation.z == 0.0f && rest[k].local_rotation.w == 1.0f );
	}
}

// J(β) = J_template + Σ_b β_b · J_shapedirs[b], in double, b in order (the documented formula).
static void plShapedJoints( const plTestAsset* model, const float* beta, double* out )
{
	for ( uint32_t i = 0; i < model->J * 3; ++i )
	{
		double v = model->joint_template[i];
		for ( uint32_t b = 0; b < model->B; ++b )
		{
			v += (double)beta[b] * model->joint_shapedirs[(size_t)b * model->J * 3 + i];
		}
		out[i] = v;
	}
}

static void test_rest_pose_matches_the_asset_and_follows_beta( void** state )
{
	(void)state;
	plTestAsset* model = plBranchingModel();
	plTestRig rig;
	assert_int_equal( plTestRig_Init( &rig, model, NULL ), PLEAT_RESULT_OK );

	plRestJoint rest[PLEAT_MAX_JOINTS];
	double expected[PLEAT_MAX_JOINTS * 3];
	const float zero_beta[3] = { 0.0f, 0.0f, 0.0f };
	assert_int_equal( plAsset_GetRestPose( rig.asset, rest, model->J ), PLEAT_RESULT_OK );
	plShapedJoints( model, zero_beta, expected );
	plExpectRestPose( rest, model, expected );

	const float beta[3] = { 1.5f, -2.0f, 0.75f };
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = rig.asset;
	idef.beta = beta;
	idef.beta_count = 3;
	plInstance inst;
	assert_int_equal( plCreateInstance( rig.context, &idef, &inst ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetRestPose( inst, rest, PLEAT_MAX_JOINTS ), PLEAT_RESULT_OK );
	plShapedJoints( model, beta, expected );
	plExpectRestPose( rest, model, expected );
	// The β = 0 pose differs (the test's shape directions are not zero), so the instance's is really J(β).
	plRestJoint mean[PLEAT_MAX_JOINTS];
	assert_int_equal( plAsset_GetRestPose( rig.asset, mean, PLEAT_MAX_JOINTS ), PLEAT_RESULT_OK );
	assert_true( memcmp( mean, rest, model->J * sizeof( plRestJoint ) ) != 0 );

	const float other_beta[2] = { -0.5f, 1.0f };
	assert_int_equal( plInstance_SetShape( inst, other_beta, 2 ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetRestPose( inst, rest, model->J ), PLEAT_RESULT_OK );
	const float other_full[3] = { -0.5f, 1.0f, 0.0f };
	plShapedJoints( model, other_full, expected );
	plExpectRestPose( rest, model, expected );

	plTestRig_Free( &rig );
	plTestAsset_Destroy( model );
}

static void test_rest_pose_rejects_bad_arguments_and_writes_nothing( void** state )
{
	(void)state;
	plTestAsset* model = plBranchingModel();
	plTestRig rig;
	assert_int_equal( plTestRig_Init( &rig, model, NULL ), PLEAT_RESULT_OK );
	plInstance inst;
	assert_int_equal( plTestRig_Instance( &rig, &inst ), PLEAT_RESULT_OK );
	plRestJoint rest[PLEAT_MAX_JOINTS], untouched[PLEAT_MAX_JOINTS];
	memset( rest, 0xAB, sizeof( rest ) );
	memcpy( untouched, rest, sizeof( rest ) );
	assert_int_equal( plAsset_GetRestPose( rig.asset, NULL, 64 ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plInstance_GetRestPose( inst, NULL, 64 ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plAsset_GetRestPose( rig.asset, rest, model->J - 1 ), PLEAT_RESULT_BUFFER_TOO_SMALL );
	assert_int_equal( plInstance_GetRestPose( inst, rest, model->J - 1 ), PLEAT_RESULT_BUFFER_TOO_SMALL );
	plAsset null_asset = { 0, 0, { 0, 0 } };
	plInstance null_instance = { 0, 0, { 0, 0 } };
	assert_int_equal( plAsset_GetRestPose( null_asset, rest, 64 ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( plInstance_GetRestPose( null_instance, rest, 64 ), PLEAT_RESULT_INVALID_HANDLE );
	plInstance stale = inst;
	assert_int_equal( plDestroyInstance( inst ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetRestPose( stale, rest, 64 ), PLEAT_RESULT_INVALID_HANDLE );
	assert_memory_equal( rest, untouched, sizeof( rest ) );
	plTestRig_Free( &rig );
	plTestAsset_Destroy( model );
}

// ---- the T-pose retarget on the shipped t-shirt ----

static void plQuatMul( double* out, const double* a, const double* b )
{
	double r[4] = {
		a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1],
		a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0],
		a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3],
		a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2],
	};
	memcpy( out, r, sizeof( r ) );
}

static void plQuatAxisAngle( double* q, double x, double y, double z, double angle )
{
	double n = sqrt( x * x + y * y + z * z ), s = sin( 0.5 * angle ) / n;
	q[0] = x * s, q[1] = y * s, q[2] = z * s, q[3] = cos( 0.5 * angle );
}

// Largest component difference of two rotations, sign-insensitive (q and −q are one rotation).
static double plQuatDistance( const double* a, const float* b )
{
	double plus = 0.0, minus = 0.0;
	for ( int c = 0; c < 4; ++c )
	{
		plus = fmax( plus, fabs( a[c] - b[c] ) );
		minus = fmax( minus, fabs( a[c] + b[c] ) );
	}
	return fmin( plus, minus );
}

typedef struct plTPoseRig
{
	plContext context;
	plAsset asset;
	plAssetInfo info;
	plRestJoint rest[PLEAT_MAX_JOINTS]; // the instance's J(β)
	// The engine: "root_motion", then the asset's joints but the hands, in breadth-first order (not the asset's).
	uint32_t engine_count;
	const char* names[PLEAT_MAX_JOINTS + 1];
	int32_t parents[PLEAT_MAX_JOINTS + 1];
	float bind_positions[PLEAT_MAX_JOINTS + 1][3]; // the asset's rest joints with the arms raised to horizontal
	int32_t engine_of_asset[PLEAT_MAX_JOINTS];     // -1: the engine lacks it (the hands)
	int32_t asset_of_engine[PLEAT_MAX_JOINTS + 1]; // -1: root_motion
	double arm_raise[PLEAT_MAX_JOINTS][4];         // O_k by construction: Rz(±arm angle) on each arm, else identity
} plTPoseRig;

static int plJoint( const plTPoseRig* rig, const char* name )
{
	int32_t k = -1;
	plAsset_FindJoint( rig->asset, name, &k );
	assert_true( k >= 0 );
	return k;
}

// Whether asset joint k is `ancestor` or below it.
static int plBelow( const plTPoseRig* rig, int k, int ancestor )
{
	for ( ; k >= 0; k = rig->rest[k].parent )
	{
		if ( k == ancestor )
			return 1;
	}
	return 0;
}

static void plTPoseRig_Init( plTPoseRig* rig, const float* beta, uint32_t beta_count )
{
	memset( rig, 0, sizeof( *rig ) );
	plContextDef cdef = plDefaultContextDef();
	assert_int_equal( plCreateContext( &cdef, &rig->context ), PLEAT_RESULT_OK );
	plAssetDef adef = plDefaultAssetDef();
	adef.path = s_shipped_asset_path;
	assert_int_equal( plLoadAsset( rig->context, &adef, &rig->asset ), PLEAT_RESULT_OK );
	assert_int_equal( plAsset_GetInfo( rig->asset, &rig->info ), PLEAT_RESULT_OK );
	// The rest pose of this β, from a throwaway instance (the retarget's instance is created by the test).
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = rig->asset;
	idef.beta = beta;
	idef.beta_count = beta_count;
	plInstance probe;
	assert_int_equal( plCreateInstance( rig->context, &idef, &probe ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetRestPose( probe, rig->rest, PLEAT_MAX_JOINTS ), PLEAT_RESULT_OK );
	plDestroyInstance( probe );
	uint32_t J = rig->info.joint_count;

	// The arms: each raised through its shoulder joint by the smallest rotation that makes the upper arm horizontal
	// (about the axis upper arm × its horizontal projection: +Z for the left arm, −Z for the right, up to the arm's
	// slight forward lean).
	for ( uint32_t k = 0; k < J; ++k )
		plQuatAxisAngle( rig->arm_raise[k], 0.0, 0.0, 1.0, 0.0 );
	const char* shoulders[2] = { "left_shoulder", "right_shoulder" };
	const char* elbows[2] = { "left_elbow", "right_elbow" };
	float positions[PLEAT_MAX_JOINTS][3];
	for ( uint32_t k = 0; k < J; ++k )
	{
		positions[k][0] = rig->rest[k].position.x;
		positions[k][1] = rig->rest[k].position.y + 0.97f; // the engine's origin is on the floor
		positions[k][2] = rig->rest[k].position.z;
	}
	for ( int side = 0; side < 2; ++side )
	{
		int shoulder = plJoint( rig, shoulders[side] ), elbow = plJoint( rig, elbows[side] );
		double a[3] = { rig->rest[elbow].position.x - rig->rest[shoulder].position.x,
						rig->rest[elbow].position.y - rig->rest[shoulder].position.y,
						rig->rest[elbow].position.z - rig->rest[shoulder].position.z };
		double h[3] = { a[0], 0.0, a[2] };
		double axis[3] = { a[1] * h[2] - a[2] * h[1], a[2] * h[0] - a[0] * h[2], a[0] * h[1] - a[1] * h[0] };
		double la = sqrt( a[0] * a[0] + a[1] * a[1] + a[2] * a[2] ), lh = sqrt( h[0] * h[0] + h[2] * h[2] );
		double angle = acos( fmin( 1.0, ( a[0] * h[0] + a[2] * h[2] ) / ( la * lh ) ) );
		assert_true( fabs( angle - 25.0 * PL_PI / 180.0 ) < 2.0 * PL_PI / 180.0 ); // the documented A-pose
		assert_true( fabs( axis[2] ) > 0.99 * sqrt( axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2] ) );
		double raise[4];
		plQuatAxisAngle( raise, axis[0], axis[1], axis[2], angle );
		for ( uint32_t k = 0; k < J; ++k )
		{
			if ( !plBelow( rig, (int)k, shoulder ) )
				continue;
			memcpy( rig->arm_raise[k], raise, sizeof( raise ) );
			// p' = shoulder + raise · (p − shoulder), by v' = v + 2w(u × v) + 2u × (u × v), u = raise's vector part.
			double v[3] = { positions[k][0] - positions[shoulder][0], positions[k][1] - positions[shoulder][1],
							positions[k][2] - positions[shoulder][2] };
			double t[3] = { 2.0 * ( raise[1] * v[2] - raise[2] * v[1] ), 2.0 * ( raise[2] * v[0] - raise[0] * v[2] ),
							2.0 * ( raise[0] * v[1] - raise[1] * v[0] ) };
			double ut[3] = { raise[1] * t[2] - raise[2] * t[1], raise[2] * t[0] - raise[0] * t[2],
							 raise[0] * t[1] - raise[1] * t[0] };
			for ( int c = 0; c < 3; ++c )
				positions[k][c] = positions[shoulder][c] + (float)( v[c] + raise[3] * t[c] + ut[c] );
		}
	}

	// Engine order: root_motion, then breadth-first over the asset's tree, hands left out.
	int lh = plJoint( rig, "left_hand" ), rh = plJoint( rig, "right_hand" );
	for ( uint32_t k = 0; k < J; ++k )
		rig->engine_of_asset[k] = -1;
	rig->names[0] = "root_motion";
	rig->parents[0] = -1;
	rig->asset_of_engine[0] = -1;
	rig->engine_count = 1;
	for ( int depth = 0; depth < (int)J; ++depth )
	{
		for ( uint32_t k = 0; k < J; ++k )
		{
			int d = 0;
			for ( int p = rig->rest[k].parent; p >= 0; p = rig->rest[p].parent )
				++d;
			if ( d != depth || (int)k == lh || (int)k == rh )
				continue;
			uint32_t e = rig->engine_count++;
			rig->engine_of_asset[k] = (int32_t)e;
			rig->asset_of_engine[e] = (int32_t)k;
			assert_int_equal( plAsset_GetJointName( rig->asset, k, &rig->names[e] ), PLEAT_RESULT_OK );
			int32_t parent = rig->rest[k].parent;
			rig->parents[e] = parent >= 0 ? rig->engine_of_asset[parent] : 0;
			memcpy( rig->bind_positions[e], positions[k], sizeof( positions[k] ) );
		}
	}
	assert_int_equal( rig->engine_count, J - 1 ); // + root_motion − two hands
}

// Frame f of an engine motion relative to its T-pose: every engine joint swings about its own axis; the arms come
// down to the sides (about 70°–100° below horizontal).
static void plEngineMotion( const plTPoseRig* rig, uint32_t frame, float* engine_rotations )
{
	double t = frame / 30.0;
	for ( uint32_t e = 0; e < rig->engine_count; ++e )
	{
		double q[4];
		double angle = e == 0 ? 0.0 : 0.35 * sin( 2.0 * t + e );
		plQuatAxisAngle( q, 0.3 + 0.05 * e, 0.5, 0.8 - 0.03 * e, angle );
		int k = rig->asset_of_engine[e];
		const char* name = k >= 0 ? rig->names[e] : "";
		if ( strcmp( name, "left_shoulder" ) == 0 || strcmp( name, "right_shoulder" ) == 0 )
		{
			double down[4], sign = strcmp( name, "left_shoulder" ) == 0 ? -1.0 : 1.0;
			plQuatAxisAngle( down, 0.0, 0.0, 1.0, sign * ( 1.4 + 0.25 * sin( 3.0 * t ) ) );
			plQuatMul( q, down, q );
		}
		for ( int c = 0; c < 4; ++c )
			engine_rotations[e * 4 + c] = (float)q[c];
	}
}

// What the asset takes for the same physical pose, by hand from the construction (retarget.h's formula with the
// engine's topology equal to the asset's): R_k = O_parent⁻¹ · q_e · O_k, O = the arm raise; the hands identity.
static void plExpectedAssetRotations( const plTPoseRig* rig, const float* engine_rotations, double* out )
{
	for ( uint32_t k = 0; k < rig->info.joint_count; ++k )
	{
		double* r = out + 4 * k;
		int32_t e = rig->engine_of_asset[k];
		if ( e < 0 )
		{
			plQuatAxisAngle( r, 0.0, 0.0, 1.0, 0.0 );
			continue;
		}
		double q[4], parent_inverse[4] = { 0.0, 0.0, 0.0, 1.0 };
		for ( int c = 0; c < 4; ++c )
			q[c] = engine_rotations[e * 4 + c];
		int32_t parent = rig->rest[k].parent;
		if ( parent >= 0 )
		{
			const double* o = rig->arm_raise[parent];
			parent_inverse[0] = -o[0], parent_inverse[1] = -o[1], parent_inverse[2] = -o[2], parent_inverse[3] = o[3];
		}
		plQuatMul( r, parent_inverse, q );
		plQuatMul( r, r, rig->arm_raise[k] );
	}
}

static void plRequireShippedAsset( void )
{
	FILE* f = s_shipped_asset_path != NULL ? fopen( s_shipped_asset_path, "rb" ) : NULL;
	if ( f == NULL )
	{
		print_message( "SKIP: the shipped asset (argument 1) is not readable\n" );
		skip();
	}
	fclose( f );
}

static void test_t_pose_bind_pose_retargets_to_the_asset_a_pose( void** state )
{
	(void)state;
	plRequireShippedAsset();
	const float beta[2] = { 0.8f, -1.2f };
	static plTPoseRig rig;
	plTPoseRig_Init( &rig, beta, 2 );
	const EngineSkeleton engine = { rig.engine_count, rig.names, rig.parents, &rig.bind_positions[0][0], NULL };
	static Retarget retarget;
	assert_int_equal( retargetInit( &retarget, &engine, rig.asset ), PLEAT_RESULT_OK );
	assert_int_equal( retargetSetRestPose( &retarget, rig.rest ), PLEAT_RESULT_OK );
	for ( uint32_t k = 0; k < rig.info.joint_count; ++k )
		assert_int_equal( retarget.joint_map[k], rig.engine_of_asset[k] );

	// The engine at its bind pose (all identity) is the asset's A-pose with the shoulders raised by the arm angle.
	float identity[PLEAT_MAX_JOINTS + 1][4] = { { 0 } }, out[PLEAT_MAX_JOINTS + 1][4];
	for ( uint32_t e = 0; e < rig.engine_count; ++e )
		identity[e][3] = 1.0f;
	retargetPose( &retarget, &identity[0][0], &out[0][0] );
	double worst = 0.0;
	for ( uint32_t k = 0; k < rig.info.joint_count; ++k )
	{
		int32_t e = rig.engine_of_asset[k];
		if ( e < 0 )
			continue;
		int shoulder = strstr( rig.names[e], "_shoulder" ) != NULL;
		double expected[4];
		memcpy( expected, rig.arm_raise[k], sizeof( expected ) );
		if ( !shoulder )
			plQuatAxisAngle( expected, 0.0, 0.0, 1.0, 0.0 ); // elbow, wrist: O_parent⁻¹ · O_k = identity
		worst = fmax( worst, plQuatDistance( expected, out[e] ) );
	}
	print_message( "bind pose: largest quaternion component error %.2g\n", worst );
	assert_true( worst < 1e-5 );
	plDestroyContext( rig.context );
}

// The whole point: the cloth from the engine's T-pose-relative motion through the retarget equals the cloth from the
// hand-derived A-pose-relative rotations, and feeding the T-pose-relative rotations unretargeted does not.
static void test_t_pose_retarget_gives_the_cloth_of_rest_relative_rotations( void** state )
{
	(void)state;
	plRequireShippedAsset();
	const float beta[2] = { 0.8f, -1.2f };
	static plTPoseRig rig;
	plTPoseRig_Init( &rig, beta, 2 );
	uint32_t J = rig.info.joint_count, N = rig.info.vertex_count;

	const EngineSkeleton engine = { rig.engine_count, rig.names, rig.parents, &rig.bind_positions[0][0], NULL };
	static Retarget retarget;
	assert_int_equal( retargetInit( &retarget, &engine, rig.asset ), PLEAT_RESULT_OK );
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = rig.asset;
	idef.beta = beta;
	idef.beta_count = 2;
	plInstance direct, wrong;
	assert_int_equal( plCreateInstance( rig.context, &idef, &direct ), PLEAT_RESULT_OK );
	assert_int_equal( plCreateInstance( rig.context, &idef, &wrong ), PLEAT_RESULT_OK );
	idef.joint_map = retarget.joint_map;
	idef.joint_map_count = J;
	idef.engine_joint_count = rig.engine_count;
	plInstance retargeted;
	assert_int_equal( plCreateInstance( rig.context, &idef, &retargeted ), PLEAT_RESULT_OK );
	plRestJoint rest[PLEAT_MAX_JOINTS];
	assert_int_equal( plInstance_GetRestPose( retargeted, rest, J ), PLEAT_RESULT_OK );
	assert_int_equal( retargetSetRestPose( &retarget, rest ), PLEAT_RESULT_OK );

	double worst_rotation = 0.0, worst_position = 0.0, smallest_wrong = INFINITY;
	for ( uint32_t frame = 0; frame < 30; ++frame )
	{
		float engine_rotations[PLEAT_MAX_JOINTS + 1][4], retargeted_rotations[PLEAT_MAX_JOINTS + 1][4];
		double expected[PLEAT_MAX_JOINTS][4];
		float direct_rotations[PLEAT_MAX_JOINTS][4], unretargeted[PLEAT_MAX_JOINTS][4];
		plEngineMotion( &rig, frame, &engine_rotations[0][0] );
		retargetPose( &retarget, &engine_rotations[0][0], &retargeted_rotations[0][0] );
		plExpectedAssetRotations( &rig, &engine_rotations[0][0], &expected[0][0] );
		for ( uint32_t k = 0; k < J; ++k )
		{
			int32_t e = rig.engine_of_asset[k];
			for ( int c = 0; c < 4; ++c )
			{
				direct_rotations[k][c] = (float)expected[k][c];
				unretargeted[k][c] = e >= 0 ? engine_rotations[e][c] : ( c == 3 ? 1.0f : 0.0f );
			}
			if ( e >= 0 )
				worst_rotation = fmax( worst_rotation, plQuatDistance( expected[k], retargeted_rotations[e] ) );
		}
		plFrameInput in;
		memset( &in, 0, sizeof( in ) );
		in.root_translation.z = 0.04f * (float)frame;
		in.root_rotation.w = 1.0f;
		in.dt_s = 1.0f / 30.0f;
		in.joint_stride_bytes = 16;
		in.joint_rotations = &direct_rotations[0][0];
		in.joint_count = J;
		assert_true( plInstance_Step( direct, &in, NULL ) >= 0 );
		in.joint_rotations = &unretargeted[0][0];
		assert_true( plInstance_Step( wrong, &in, NULL ) >= 0 );
		in.joint_rotations = &retargeted_rotations[0][0];
		in.joint_count = rig.engine_count;
		assert_true( plInstance_Step( retargeted, &in, NULL ) >= 0 );

		const float *a, *b, *w;
		assert_int_equal( plInstance_GetPositions( direct, &a, NULL ), PLEAT_RESULT_OK );
		assert_int_equal( plInstance_GetPositions( retargeted, &b, NULL ), PLEAT_RESULT_OK );
		assert_int_equal( plInstance_GetPositions( wrong, &w, NULL ), PLEAT_RESULT_OK );
		double frame_wrong = 0.0;
		for ( uint32_t i = 0; i < N * 3; ++i )
		{
			worst_position = fmax( worst_position, fabs( (double)a[i] - b[i] ) );
			frame_wrong = fmax( frame_wrong, fabs( (double)a[i] - w[i] ) );
		}
		smallest_wrong = fmin( smallest_wrong, frame_wrong );
	}
	print_message( "30 frames: rotations within %.2g, positions within %.3g mm; unretargeted T-pose rotations are "
				   "off by at least %.0f mm\n",
				   worst_rotation, worst_position * 1e3, smallest_wrong * 1e3 );
	assert_true( worst_rotation < 1e-5 );
	assert_true( worst_position < 1e-5 ); // 0.01 mm: float rounding of two routes to the same rotations
	assert_true( smallest_wrong > 0.02 ); // the 25° is centimetres of sleeve: the check has teeth
	plDestroyContext( rig.context );
}

// An engine whose joint frames are not model-aligned (bind local rotations ≠ identity), playing the same physical
// motion, retargets to the same rotations: B_e cancels in Δ_e = G_e · B_e⁻¹.
static void test_retarget_reads_the_engine_bind_rotations( void** state )
{
	(void)state;
	plRequireShippedAsset();
	const float beta[1] = { 0.0f };
	static plTPoseRig rig;
	plTPoseRig_Init( &rig, beta, 1 );
	const EngineSkeleton aligned = { rig.engine_count, rig.names, rig.parents, &rig.bind_positions[0][0], NULL };
	// Frame of engine joint e: a fixed rotation F_e; bind local = F_parent⁻¹ · F_e; pose local = F_parent⁻¹ · q · F_e.
	double frames[PLEAT_MAX_JOINTS + 1][4];
	float bind_local[PLEAT_MAX_JOINTS + 1][4];
	for ( uint32_t e = 0; e < rig.engine_count; ++e )
	{
		plQuatAxisAngle( frames[e], 1.0 + e % 3, 2.0 - e % 2, 0.5 * e, 0.3 + 0.2 * e );
		double parent_inverse[4] = { 0.0, 0.0, 0.0, 1.0 }, local[4];
		if ( rig.parents[e] >= 0 )
		{
			const double* f = frames[rig.parents[e]];
			parent_inverse[0] = -f[0], parent_inverse[1] = -f[1], parent_inverse[2] = -f[2], parent_inverse[3] = f[3];
		}
		plQuatMul( local, parent_inverse, frames[e] );
		for ( int c = 0; c < 4; ++c )
			bind_local[e][c] = (float)local[c];
	}
	const EngineSkeleton framed = { rig.engine_count, rig.names, rig.parents, &rig.bind_positions[0][0],
									&bind_local[0][0] };
	static Retarget plain, rotated;
	assert_int_equal( retargetInit( &plain, &aligned, rig.asset ), PLEAT_RESULT_OK );
	assert_int_equal( retargetInit( &rotated, &framed, rig.asset ), PLEAT_RESULT_OK );
	double worst = 0.0;
	for ( uint32_t frame = 0; frame < 10; ++frame )
	{
		float motion[PLEAT_MAX_JOINTS + 1][4], framed_motion[PLEAT_MAX_JOINTS + 1][4];
		float out_plain[PLEAT_MAX_JOINTS + 1][4], out_rotated[PLEAT_MAX_JOINTS + 1][4];
		plEngineMotion( &rig, frame, &motion[0][0] );
		for ( uint32_t e = 0; e < rig.engine_count; ++e )
		{
			double q[4] = { motion[e][0], motion[e][1], motion[e][2], motion[e][3] }, r[4];
			double parent_inverse[4] = { 0.0, 0.0, 0.0, 1.0 };
			if ( rig.parents[e] >= 0 )
			{
				const double* f = frames[rig.parents[e]];
				parent_inverse[0] = -f[0], parent_inverse[1] = -f[1], parent_inverse[2] = -f[2];
				parent_inverse[3] = f[3];
			}
			plQuatMul( r, parent_inverse, q );
			plQuatMul( r, r, frames[e] );
			for ( int c = 0; c < 4; ++c )
				framed_motion[e][c] = (float)r[c];
		}
		retargetPose( &plain, &motion[0][0], &out_plain[0][0] );
		retargetPose( &rotated, &framed_motion[0][0], &out_rotated[0][0] );
		for ( uint32_t e = 0; e < rig.engine_count; ++e )
		{
			double a[4] = { out_plain[e][0], out_plain[e][1], out_plain[e][2], out_plain[e][3] };
			worst = fmax( worst, plQuatDistance( a, out_rotated[e] ) );
		}
	}
	print_message( "rotated engine joint frames: largest difference %.2g\n", worst );
	assert_true( worst < 1e-5 );
	plDestroyContext( rig.context );
}

static void test_retarget_rejects_a_bad_engine_skeleton( void** state )
{
	(void)state;
	plTestAsset* model = plBranchingModel();
	plTestRig rig;
	assert_int_equal( plTestRig_Init( &rig, model, NULL ), PLEAT_RESULT_OK );
	// The builder names its joints; two engine joints with one asset name would drive one joint twice.
	const char* name0;
	assert_int_equal( plAsset_GetJointName( rig.asset, 0, &name0 ), PLEAT_RESULT_OK );
	const char* names[3] = { name0, name0, "unknown" };
	int32_t parents[3] = { -1, 0, 1 };
	float positions[3][3] = { { 0 } };
	EngineSkeleton engine = { 3, names, parents, &positions[0][0], NULL };
	static Retarget retarget;
	assert_int_equal( retargetInit( &retarget, &engine, rig.asset ), PLEAT_RESULT_INVALID_ARGUMENT );
	names[1] = "other";
	parents[1] = 2; // a child before its parent
	assert_int_equal( retargetInit( &retarget, &engine, rig.asset ), PLEAT_RESULT_INVALID_ARGUMENT );
	parents[1] = 0;
	assert_int_equal( retargetInit( &retarget, &engine, rig.asset ), PLEAT_RESULT_OK );
	assert_int_equal( retarget.joint_map[0], 0 );
	for ( uint32_t k = 1; k < model->J; ++k )
		assert_int_equal( retarget.joint_map[k], -1 );
	plTestRig_Free( &rig );
	plTestAsset_Destroy( model );
}

int main( int argc, char** argv )
{
	s_shipped_asset_path = argc > 1 ? argv[1] : NULL;
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_rest_pose_matches_the_asset_and_follows_beta ),
		cmocka_unit_test( test_rest_pose_rejects_bad_arguments_and_writes_nothing ),
		cmocka_unit_test( test_t_pose_bind_pose_retargets_to_the_asset_a_pose ),
		cmocka_unit_test( test_t_pose_retarget_gives_the_cloth_of_rest_relative_rotations ),
		cmocka_unit_test( test_retarget_reads_the_engine_bind_rotations ),
		cmocka_unit_test( test_retarget_rejects_a_bad_engine_skeleton ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
