// Sample code: retarget from an engine bind pose to Pleat's rest-relative rotations (retarget.h has the math).
#include "retarget.h"

#include <math.h>
#include <string.h>

// ---- quaternions (x, y, z, w) and 3-vectors, float ----

static void quatIdentity( float* q )
{
	q[0] = q[1] = q[2] = 0.0f;
	q[3] = 1.0f;
}

static void quatCopy( float* out, const float* q )
{
	memcpy( out, q, 4 * sizeof( float ) );
}

// out = a · b (apply b, then a). out may alias a or b.
static void quatMul( float* out, const float* a, const float* b )
{
	float r[4] = {
		a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1],
		a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0],
		a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3],
		a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2],
	};
	quatCopy( out, r );
}

// Inverse of a unit quaternion.
static void quatConjugate( float* out, const float* q )
{
	out[0] = -q[0], out[1] = -q[1], out[2] = -q[2], out[3] = q[3];
}

static void quatNormalize( float* q )
{
	float n = sqrtf( q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] );
	if ( n > 0.0f )
		q[0] /= n, q[1] /= n, q[2] /= n, q[3] /= n;
	else
		quatIdentity( q );
}

static void quatRotate( float* out, const float* q, const float* v )
{
	float p[4] = { v[0], v[1], v[2], 0.0f }, c[4], t[4];
	quatConjugate( c, q );
	quatMul( t, q, p );
	quatMul( t, t, c );
	out[0] = t[0], out[1] = t[1], out[2] = t[2];
}

static float dot3( const float* a, const float* b )
{
	return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3( float* out, const float* a, const float* b )
{
	float r[3] = { a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0] };
	memcpy( out, r, sizeof( r ) );
}

// Normalises v in place; returns its length before (0 leaves v as it was).
static float normalize3( float* v )
{
	float n = sqrtf( dot3( v, v ) );
	if ( n > 0.0f )
		v[0] /= n, v[1] /= n, v[2] /= n;
	return n;
}

// The smallest rotation taking unit vector u onto unit vector v.
static void quatShortestArc( float* q, const float* u, const float* v )
{
	float d = dot3( u, v );
	if ( d < -0.999999f )
	{
		// Opposite: half a turn about any axis perpendicular to u.
		float axis[3], x[3] = { 1.0f, 0.0f, 0.0f }, y[3] = { 0.0f, 1.0f, 0.0f };
		cross3( axis, fabsf( u[0] ) < 0.9f ? x : y, u );
		normalize3( axis );
		q[0] = axis[0], q[1] = axis[1], q[2] = axis[2], q[3] = 0.0f;
		return;
	}
	float c[3];
	cross3( c, u, v );
	q[0] = c[0], q[1] = c[1], q[2] = c[2], q[3] = 1.0f + d;
	quatNormalize( q );
}

// ---- building ----

// O_k from the directions of k's children that both skeletons have, starting from the parent's offset: the first
// child's direction is matched exactly by the smallest further rotation (so a bone that sits on its parent the same
// way in both rest poses gets exactly its parent's offset, and an identity rotation at the bind pose); the child most
// perpendicular to it, when there is one, then fixes the twist about it. A joint with no such child keeps its
// parent's offset (it moves rigidly with its parent between the two rest poses).
static void buildRestOffsets( Retarget* r, const plRestJoint* rest )
{
	for ( uint32_t k = 0; k < r->asset_joint_count; ++k )
	{
		float* offset = r->rest_offsets[k];
		int32_t parent = r->asset_parents[k];
		if ( parent >= 0 )
			quatCopy( offset, r->rest_offsets[parent] );
		else
			quatIdentity( offset );
		int32_t e = r->joint_map[k];
		if ( e < 0 )
			continue;
		float asset_dirs[PLEAT_MAX_JOINTS][3], engine_dirs[PLEAT_MAX_JOINTS][3];
		uint32_t count = 0;
		for ( uint32_t c = k + 1; c < r->asset_joint_count; ++c )
		{
			int32_t ec = r->joint_map[c];
			if ( r->asset_parents[c] != (int32_t)k || ec < 0 )
				continue;
			float* a = asset_dirs[count];
			float* b = engine_dirs[count];
			a[0] = rest[c].position.x - rest[k].position.x;
			a[1] = rest[c].position.y - rest[k].position.y;
			a[2] = rest[c].position.z - rest[k].position.z;
			for ( int i = 0; i < 3; ++i )
				b[i] = r->engine_bind_positions[ec][i] - r->engine_bind_positions[e][i];
			if ( normalize3( a ) > 1e-6f && normalize3( b ) > 1e-6f )
				count += 1;
		}
		if ( count == 0 )
			continue;
		float moved_first[3], swing[4];
		quatRotate( moved_first, offset, asset_dirs[0] );
		normalize3( moved_first );
		quatShortestArc( swing, moved_first, engine_dirs[0] );
		quatMul( offset, swing, offset );
		quatNormalize( offset );
		uint32_t second = 0;
		float best = 0.9f; // |cos| above this (within ~25° of the first) says too little about the twist
		for ( uint32_t i = 1; i < count; ++i )
		{
			float c = fabsf( dot3( asset_dirs[0], asset_dirs[i] ) );
			if ( c < best )
				best = c, second = i;
		}
		if ( second == 0 )
			continue;
		// Twist about the (now matched) first direction that turns the second child's direction, projected on the
		// plane perpendicular to it, onto the engine's.
		const float* axis = engine_dirs[0];
		float moved[3], a2[3], e2[3];
		quatRotate( moved, offset, asset_dirs[second] );
		float da = dot3( moved, axis ), de = dot3( engine_dirs[second], axis );
		for ( int i = 0; i < 3; ++i )
		{
			a2[i] = moved[i] - da * axis[i];
			e2[i] = engine_dirs[second][i] - de * axis[i];
		}
		if ( normalize3( a2 ) < 1e-6f || normalize3( e2 ) < 1e-6f )
			continue;
		float twist[4];
		quatShortestArc( twist, a2, e2 ); // a2 and e2 are both perpendicular to axis: the arc is about ±axis
		quatMul( offset, twist, offset );
		quatNormalize( offset );
	}
}

plResult retargetInit( Retarget* retarget, const EngineSkeleton* engine, plAsset asset )
{
	if ( retarget == NULL || engine == NULL || engine->names == NULL || engine->parents == NULL ||
		 engine->bind_positions == NULL || engine->joint_count == 0 || engine->joint_count > RETARGET_MAX_ENGINE_JOINTS )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	memset( retarget, 0, sizeof( *retarget ) );
	plRestJoint rest[PLEAT_MAX_JOINTS];
	plAssetInfo info;
	plResult result = plAsset_GetInfo( asset, &info );
	if ( result == PLEAT_RESULT_OK )
		result = plAsset_GetRestPose( asset, rest, PLEAT_MAX_JOINTS );
	if ( result != PLEAT_RESULT_OK )
		return result;
	retarget->asset_joint_count = info.joint_count;
	retarget->engine_joint_count = engine->joint_count;

	// The engine's bind world rotations B_e (parents first, as the engine stores them).
	for ( uint32_t e = 0; e < engine->joint_count; ++e )
	{
		int32_t parent = engine->parents[e];
		if ( parent >= (int32_t)e || parent < -1 )
			return PLEAT_RESULT_INVALID_ARGUMENT;
		retarget->engine_parents[e] = parent;
		memcpy( retarget->engine_bind_positions[e], engine->bind_positions + 3 * e, 3 * sizeof( float ) );
		float local[4];
		if ( engine->bind_local_rotations != NULL )
		{
			quatCopy( local, engine->bind_local_rotations + 4 * e );
			quatNormalize( local );
		}
		else
			quatIdentity( local );
		if ( parent >= 0 )
			quatMul( retarget->engine_bind_world[e], retarget->engine_bind_world[parent], local );
		else
			quatCopy( retarget->engine_bind_world[e], local );
	}

	// Joint map by name; an engine joint may drive one asset joint only.
	for ( uint32_t k = 0; k < info.joint_count; ++k )
	{
		retarget->asset_parents[k] = rest[k].parent;
		retarget->joint_map[k] = -1;
	}
	for ( uint32_t e = 0; e < engine->joint_count; ++e )
	{
		int32_t k;
		if ( engine->names[e] == NULL || plAsset_FindJoint( asset, engine->names[e], &k ) != PLEAT_RESULT_OK )
			continue;
		if ( retarget->joint_map[k] >= 0 )
			return PLEAT_RESULT_INVALID_ARGUMENT;
		retarget->joint_map[k] = (int32_t)e;
	}
	buildRestOffsets( retarget, rest );
	return PLEAT_RESULT_OK;
}

plResult retargetSetRestPose( Retarget* retarget, const plRestJoint* rest )
{
	if ( retarget == NULL || rest == NULL )
		return PLEAT_RESULT_INVALID_ARGUMENT;
	for ( uint32_t k = 0; k < retarget->asset_joint_count; ++k )
	{
		if ( rest[k].parent != retarget->asset_parents[k] )
			return PLEAT_RESULT_INVALID_ARGUMENT; // not this asset's skeleton
	}
	buildRestOffsets( retarget, rest );
	return PLEAT_RESULT_OK;
}

// ---- per frame ----

void retargetPose( const Retarget* r, const float* engine_local_rotations, float* out_rotations )
{
	// Engine forward kinematics (rotations only), then Δ_e = G_e · B_e⁻¹.
	float world[RETARGET_MAX_ENGINE_JOINTS][4], delta[RETARGET_MAX_ENGINE_JOINTS][4];
	for ( uint32_t e = 0; e < r->engine_joint_count; ++e )
	{
		float local[4], bind_inverse[4];
		quatCopy( local, engine_local_rotations + 4 * e );
		quatNormalize( local );
		if ( r->engine_parents[e] >= 0 )
			quatMul( world[e], world[r->engine_parents[e]], local );
		else
			quatCopy( world[e], local );
		quatConjugate( bind_inverse, r->engine_bind_world[e] );
		quatMul( delta[e], world[e], bind_inverse );
		quatIdentity( out_rotations + 4 * e );
	}
	// Asset joints, parents first: W_k = Δ_e · O_k, R_k = W_parent⁻¹ · W_k; a joint without an engine joint keeps
	// R_k = identity, so W_k = W_parent.
	float asset_world[PLEAT_MAX_JOINTS][4];
	for ( uint32_t k = 0; k < r->asset_joint_count; ++k )
	{
		int32_t e = r->joint_map[k];
		int32_t parent = r->asset_parents[k];
		float parent_world[4];
		if ( parent >= 0 )
			quatCopy( parent_world, asset_world[parent] );
		else if ( e >= 0 && r->engine_parents[e] >= 0 )
			quatCopy( parent_world, delta[r->engine_parents[e]] ); // the root motion's frame
		else
			quatIdentity( parent_world );
		if ( e < 0 )
		{
			quatCopy( asset_world[k], parent_world );
			continue;
		}
		float parent_inverse[4], local[4];
		quatMul( asset_world[k], delta[e], r->rest_offsets[k] );
		quatConjugate( parent_inverse, parent_world );
		quatMul( local, parent_inverse, asset_world[k] );
		quatNormalize( local );
		quatCopy( out_rotations + 4 * e, local );
	}
}
