// The smallest complete Pleat integration: load a garment asset, map the engine's skeleton onto the asset's joints by
// name, step a procedurally swinging pose for two seconds and read the dressed garment back.
//
//     minimal path/to/garment.pleat [frames]
//
// Exits 0 and prints a summary when every output was finite.
#include <pleat/pleat.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

// An engine skeleton in the engine's own order. It has a joint the asset does not know ("root_motion") and may lack
// some the asset has: those get identity rotations through the joint map.
static const char* const s_engine_joints[] = {
	"root_motion", "pelvis",     "spine1",        "spine2",         "spine3",      "neck",         "head",
	"left_hip",    "left_knee",  "left_ankle",    "right_hip",      "right_knee",  "right_ankle",  "left_collar",
	"left_shoulder", "left_elbow", "left_wrist",  "right_collar",   "right_shoulder", "right_elbow", "right_wrist",
};
enum { ENGINE_JOINT_COUNT = sizeof( s_engine_joints ) / sizeof( s_engine_joints[0] ) };

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

	// joint_map[asset joint] = engine joint; asset joints the engine lacks stay -1 (identity).
	int32_t joint_map[PLEAT_MAX_JOINTS];
	for ( uint32_t k = 0; k < info.joint_count; ++k )
		joint_map[k] = -1;
	for ( int j = 0; j < ENGINE_JOINT_COUNT; ++j )
	{
		int32_t k;
		if ( plAsset_FindJoint( asset, s_engine_joints[j], &k ) == PLEAT_RESULT_OK )
			joint_map[k] = j;
	}

	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = asset;
	idef.joint_map = joint_map;
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

	float pose[ENGINE_JOINT_COUNT][4];
	int bad = 0;
	for ( int frame = 0; frame < frame_count && !bad; ++frame )
	{
		// A swinging walk-like pose at 60 Hz: legs and arms swing opposite, the torso twists a little.
		float t = (float)frame / 60.0f, swing = 0.5f * sinf( 2.0f * 3.14159265f * t );
		for ( int j = 0; j < ENGINE_JOINT_COUNT; ++j )
			axisAngle( pose[j], 1.0f, 0.0f, 0.0f, 0.0f );
		axisAngle( pose[engineJoint( "left_hip" )], 1.0f, 0.0f, 0.0f, swing );
		axisAngle( pose[engineJoint( "right_hip" )], 1.0f, 0.0f, 0.0f, -swing );
		axisAngle( pose[engineJoint( "left_shoulder" )], 0.0f, 0.0f, 1.0f, -1.1f + 0.4f * swing );
		axisAngle( pose[engineJoint( "right_shoulder" )], 0.0f, 0.0f, 1.0f, 1.1f + 0.4f * swing );
		axisAngle( pose[engineJoint( "spine2" )], 0.0f, 1.0f, 0.0f, 0.2f * swing );

		plFrameInput in = { 0 };
		in.joint_rotations = &pose[0][0];
		in.joint_count = ENGINE_JOINT_COUNT;
		in.joint_stride_bytes = sizeof( pose[0] );
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
