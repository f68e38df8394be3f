// The smallest complete Pleat integration: load a garment asset, retarget the engine's skeleton — bound in a T-pose,
// unlike the asset's A-pose — onto the asset's joints through the SDK's skeleton API, step a procedurally swinging
// pose for two seconds and read the dressed garment back.
//
//     minimal path/to/garment.pleat [frames]
//
// Exits 0 and prints a summary when every output was finite.
#include "retarget.h"

#include <pleat/pleat.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

// An engine skeleton in the engine's own order, bound in a T-pose (arms horizontal) with joint frames aligned to the
// model axes, as mocap skeletons are. It has a joint the asset does not know ("root_motion", whose motion the engine
// passes as root motion) and lacks some the asset has (feet, hands): those keep their rest relation to their parent.
static const char* const s_engine_joints[] = {
	"root_motion", "pelvis",     "spine1",        "spine2",         "spine3",      "neck",         "head",
	"left_hip",    "left_knee",  "left_ankle",    "right_hip",      "right_knee",  "right_ankle",  "left_collar",
	"left_shoulder", "left_elbow", "left_wrist",  "right_collar",   "right_shoulder", "right_elbow", "right_wrist",
};
enum { ENGINE_JOINT_COUNT = sizeof( s_engine_joints ) / sizeof( s_engine_joints[0] ) };
static const int32_t s_engine_parents[ENGINE_JOINT_COUNT] = {
	-1, 0, 1, 2, 3, 4, 5, 1, 7, 8, 1, 10, 11, 4, 13, 14, 15, 4, 17, 18, 19,
};
// Bind pose, model space (metres, +Y up, facing +Z, origin on the floor): the engine's own proportions, not the asset's.
static const float s_engine_bind_positions[ENGINE_JOINT_COUNT][3] = {
	{ 0.0f, 0.0f, 0.0f },      { 0.0f, 0.97f, 0.0f },       { 0.0f, 1.05f, -0.04f },    { 0.0f, 1.21f, -0.03f },
	{ 0.0f, 1.35f, -0.04f },   { 0.0f, 1.54f, 0.0f },       { 0.0f, 1.65f, 0.035f },    { 0.115f, 0.955f, -0.008f },
	{ 0.15f, 0.52f, 0.024f },  { 0.195f, 0.075f, -0.012f }, { -0.115f, 0.955f, -0.008f }, { -0.15f, 0.52f, 0.024f },
	{ -0.195f, 0.075f, -0.012f }, { 0.024f, 1.465f, 0.018f }, { 0.18f, 1.445f, 0.011f }, { 0.46f, 1.445f, 0.011f },
	{ 0.71f, 1.445f, 0.011f }, { -0.024f, 1.465f, 0.018f }, { -0.18f, 1.445f, 0.011f }, { -0.46f, 1.445f, 0.011f },
	{ -0.71f, 1.445f, 0.011f },
};

static int check( plResult result, const char* what )
{
	if ( result < 0 )
		fprintf( stderr, "minimal: %s: %s\n", what, plResultString( result ) );
	return result < 0;
}

// Rotation of angle_rad about a unit axis as (x, y, z, w).
static void axisAngle( float* q, float ax, float ay, float az, float angle_rad )
{
	float s = sinf( 0.5f * angle_rad );
	q[0] = ax * s, q[1] = ay * s, q[2] = az * s, q[3] = cosf( 0.5f * angle_rad );
}

static int engineJoint( const char* name )
{
	for ( int j = 0; j < ENGINE_JOINT_COUNT; ++j )
		if ( strcmp( s_engine_joints[j], name ) == 0 )
			return j;
	return -1;
}

int main( int argc, char** argv )
{
	const char* asset_path = argc > 1 ? argv[1] : "assets/tshirt.pleat";
	int frame_count = argc > 2 ? atoi( argv[2] ) : 120;

	plContextDef cdef = plDefaultContextDef();
	plContext context;
	if ( check( plCreateContext( &cdef, &context ), "create context" ) )
		return 1;
	plAssetDef adef = plDefaultAssetDef();
	adef.path = asset_path;
	plAsset asset;
	if ( check( plLoadAsset( context, &adef, &asset ), asset_path ) )
		return 1;
	plAssetInfo info;
	plAsset_GetInfo( asset, &info );
	printf( "minimal: %s: %u vertices, %u joints, latent %u, %u blend shapes\n", info.name, info.vertex_count,
			info.joint_count, info.latent_count, info.blend_count );

	// The retarget: joints matched by name (its joint_map goes to the instance) and, per asset joint, the rotation
	// between the asset's rest pose and the engine's bind pose, from the SDK's rest pose (samples/minimal/retarget.h).
	const EngineSkeleton engine = { ENGINE_JOINT_COUNT, s_engine_joints, s_engine_parents, &s_engine_bind_positions[0][0],
									NULL };
	static Retarget retarget; // ~10 KB: static rather than on the stack
	if ( check( retargetInit( &retarget, &engine, asset ), "retarget" ) )
		return 1;

	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = asset;
	idef.joint_map = retarget.joint_map;
	idef.joint_map_count = info.joint_count;
	idef.engine_joint_count = ENGINE_JOINT_COUNT;
	const float beta[2] = { 1.0f, -0.5f }; // a slightly taller, slimmer body than the mean
	idef.beta = beta;
	idef.beta_count = 2;
	// This loop steps at 60 Hz: run the networks at the rate they were trained at and let the steps in between pose
	// the held deformation (≈ 1.7× cheaper per frame, no measurable accuracy cost; docs/pareto.md, "Update rate").
	idef.network_rate_hz = info.train_fps;
	plInstance instance;
	if ( check( plCreateInstance( context, &idef, &instance ), "create instance" ) )
		return 1;
	// This body's rest joints J(β) (the bone directions move a little with β): rebuild the offsets from them.
	plRestJoint rest[PLEAT_MAX_JOINTS];
	if ( check( plInstance_GetRestPose( instance, rest, PLEAT_MAX_JOINTS ), "rest pose" ) ||
		 check( retargetSetRestPose( &retarget, rest ), "retarget rest pose" ) )
		return 1;

	// The engine's bind pose in the asset's terms: a T-pose is the asset's A-pose with the arms raised, so the
	// shoulders carry about 25° and (nearly) everything else is identity.
	float bind_pose[ENGINE_JOINT_COUNT][4], bind_rotations[ENGINE_JOINT_COUNT][4];
	for ( int j = 0; j < ENGINE_JOINT_COUNT; ++j )
		axisAngle( bind_pose[j], 1.0f, 0.0f, 0.0f, 0.0f );
	retargetPose( &retarget, &bind_pose[0][0], &bind_rotations[0][0] );
	printf( "minimal: T-pose engine bind pose as asset rotations (joints over 2 degrees):" );
	for ( int j = 0; j < ENGINE_JOINT_COUNT; ++j )
	{
		float degrees = 2.0f * acosf( fminf( 1.0f, fabsf( bind_rotations[j][3] ) ) ) * 57.2957795f;
		if ( degrees > 2.0f )
			printf( " %s %.1f", s_engine_joints[j], degrees );
	}
	printf( "\n" );

	float pose[ENGINE_JOINT_COUNT][4], pleat_pose[ENGINE_JOINT_COUNT][4];
	int bad = 0;
	for ( int frame = 0; frame < frame_count && !bad; ++frame )
	{
		// The engine's animation, relative to its T-pose, at 60 Hz: legs and arms swing opposite (the arms about
		// 88° down from horizontal), the torso twists a little.
		float t = (float)frame / 60.0f, swing = 0.5f * sinf( 2.0f * 3.14159265f * t );
		for ( int j = 0; j < ENGINE_JOINT_COUNT; ++j )
			axisAngle( pose[j], 1.0f, 0.0f, 0.0f, 0.0f );
		axisAngle( pose[engineJoint( "left_hip" )], 1.0f, 0.0f, 0.0f, swing );
		axisAngle( pose[engineJoint( "right_hip" )], 1.0f, 0.0f, 0.0f, -swing );
		axisAngle( pose[engineJoint( "left_shoulder" )], 0.0f, 0.0f, 1.0f, -1.54f + 0.4f * swing );
		axisAngle( pose[engineJoint( "right_shoulder" )], 0.0f, 0.0f, 1.0f, 1.54f + 0.4f * swing );
		axisAngle( pose[engineJoint( "spine2" )], 0.0f, 1.0f, 0.0f, 0.2f * swing );
		// Measured from the T-pose, these rotations would put the garment's arms 25° off: retarget them to the
		// asset's rest pose (the root motion joint is at rest, so root_rotation stays identity).
		retargetPose( &retarget, &pose[0][0], &pleat_pose[0][0] );

		plFrameInput in = { 0 };
		in.joint_rotations = &pleat_pose[0][0];
		in.joint_count = ENGINE_JOINT_COUNT;
		in.joint_stride_bytes = sizeof( pleat_pose[0] );
		in.root_translation = ( plVec3 ){ 0.0f, 0.0f, 1.2f * t }; // walking forward at 1.2 m/s
		in.root_rotation = ( plQuat ){ 0.0f, 0.0f, 0.0f, 1.0f };
		in.dt_s = 1.0f / 60.0f;
		if ( check( plInstance_Step( instance, &in, NULL ), "step" ) )
			return 1;

		const float *positions, *normals;
		uint32_t n;
		plInstance_GetPositions( instance, &positions, &n );
		plInstance_GetNormals( instance, &normals, &n );
		float lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
		for ( uint32_t i = 0; i < n * 3; ++i )
		{
			bad |= !isfinite( positions[i] ) || !isfinite( normals[i] );
			lo[i % 3] = fminf( lo[i % 3], positions[i] );
			hi[i % 3] = fmaxf( hi[i % 3], positions[i] );
		}
		if ( frame % 20 == 0 || frame == frame_count - 1 )
			printf( "frame %3d: garment bounds (%.3f %.3f %.3f) .. (%.3f %.3f %.3f) m, normal[0] (%.3f %.3f %.3f)\n",
					frame, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2], normals[0], normals[1], normals[2] );
	}

	plDestroyInstance( instance );
	plDestroyAsset( asset );
	plDestroyContext( context );
	printf( "minimal: %d frames, %s\n", frame_count, bad ? "NON-FINITE OUTPUT" : "all outputs finite" );
	return bad ? 1 : 0;
}
