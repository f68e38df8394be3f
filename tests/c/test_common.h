// Test helper: a context + asset + instance fixture over plTestAsset, and a deterministic little motion.
#ifndef PLEAT_TEST_COMMON_H
#define PLEAT_TEST_COMMON_H
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pleat/pleat.h"
#include "test_asset_builder.h"

typedef struct plTestRig
{
	plContext context;
	plAsset asset;
	uint8_t* bytes;
	size_t size;
	plAssetInfo info;
} plTestRig;

// Loads a written test asset into a fresh context (def may be NULL = defaults). Returns the load result.
static inline plResult plTestRig_Init( plTestRig* rig, plTestAsset* model, const plContextDef* def )
{
	memset( rig, 0, sizeof( *rig ) );
	plContextDef cdef = def != NULL ? *def : plDefaultContextDef();
	plResult r = plCreateContext( &cdef, &rig->context );
	if ( r != PLEAT_RESULT_OK )
	{
		return r;
	}
	rig->bytes = plTestAsset_Write( model, &rig->size );
	plAssetDef adef = plDefaultAssetDef();
	adef.data = rig->bytes;
	adef.size = rig->size;
	r = plLoadAsset( rig->context, &adef, &rig->asset );
	if ( r == PLEAT_RESULT_OK )
	{
		plAsset_GetInfo( rig->asset, &rig->info );
	}
	return r;
}

static inline void plTestRig_Free( plTestRig* rig )
{
	plDestroyContext( rig->context );
	plTestAsset_FreeBytes( rig->bytes );
}

static inline plResult plTestRig_Instance( plTestRig* rig, plInstance* out )
{
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = rig->asset;
	return plCreateInstance( rig->context, &idef, out );
}

// Frame `frame` of a smooth motion: every joint swings about an axis, the root walks and turns. quats: [J][4].
static inline plFrameInput plTestMotion( uint32_t frame, uint32_t joint_count, float* quats )
{
	float t = (float)frame / 30.0f;
	for ( uint32_t j = 0; j < joint_count; ++j )
	{
		float angle = 0.4f * sinf( 2.0f * t + (float)j );
		float ax = 0.3f, ay = 0.5f + 0.1f * (float)j, az = 0.8f;
		float n = sqrtf( ax * ax + ay * ay + az * az );
		float s = sinf( 0.5f * angle ) / n;
		quats[j * 4 + 0] = ax * s;
		quats[j * 4 + 1] = ay * s;
		quats[j * 4 + 2] = az * s;
		quats[j * 4 + 3] = cosf( 0.5f * angle );
	}
	plFrameInput in;
	memset( &in, 0, sizeof( in ) );
	in.joint_rotations = quats;
	in.joint_count = joint_count;
	in.joint_stride_bytes = 16;
	in.root_translation.x = 0.5f * t;
	in.root_translation.y = 0.02f * sinf( 6.0f * t );
	in.root_translation.z = 0.3f * sinf( t );
	float yaw = 0.6f * sinf( 0.7f * t );
	in.root_rotation.y = sinf( 0.5f * yaw );
	in.root_rotation.w = cosf( 0.5f * yaw );
	in.dt_s = 1.0f / 30.0f;
	return in;
}

#endif
