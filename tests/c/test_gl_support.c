#define _POSIX_C_SOURCE 199309L // clock_gettime
#include "test_gl_support.h"
#include <epoxy/egl.h>
#include <epoxy/gl.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static uint32_t plTestRandom( uint32_t* state )
{
	*state = *state * 1664525u + 1013904223u;
	return *state >> 8;
}

static float plTestUniform( uint32_t* state ) // [-1, 1)
{
	return (float)plTestRandom( state ) / (float)( 1u << 23 ) - 1.0f;
}

// IEEE half from float, round to nearest even (normal range only, which is all the test shapes use).
static uint16_t plTestToHalf( float value )
{
	uint32_t bits;
	memcpy( &bits, &value, 4 );
	uint32_t sign = ( bits >> 16 ) & 0x8000u;
	int32_t exponent = (int32_t)( ( bits >> 23 ) & 0xff ) - 127 + 15;
	uint32_t mantissa = bits & 0x7fffffu;
	if ( exponent <= 0 )
		return (uint16_t)sign; // flush tiny values to zero (|x| < 6e-5 m)
	uint32_t half = sign | ( (uint32_t)exponent << 10 ) | ( mantissa >> 13 );
	uint32_t rest = mantissa & 0x1fffu;
	if ( rest > 0x1000u || ( rest == 0x1000u && ( half & 1u ) ) )
		half += 1;
	return (uint16_t)half;
}

static float plTestFromHalf( uint16_t half )
{
	uint32_t sign = (uint32_t)( half & 0x8000u ) << 16;
	uint32_t exponent = ( half >> 10 ) & 0x1f;
	uint32_t mantissa = half & 0x3ffu;
	uint32_t bits = exponent == 0 ? sign : sign | ( ( exponent - 15 + 127 ) << 23 ) | ( mantissa << 13 );
	float value;
	memcpy( &value, &bits, 4 );
	return value;
}

void plTestMesh_Build( plTestMesh* mesh, uint32_t rings, uint32_t segments, uint32_t blend_count, uint32_t seed )
{
	memset( mesh, 0, sizeof( *mesh ) );
	const uint32_t n = rings * segments, f = ( rings - 1 ) * segments * 2, k = 4, j = 24;
	mesh->vertex_count = n;
	mesh->face_count = f;
	mesh->blend_count = blend_count;
	mesh->influence_count = k;
	mesh->joint_count = j;
	mesh->shaped_template = malloc( sizeof( float ) * 3 * n );
	mesh->blend_shapes = malloc( sizeof( float ) * 3 * n * blend_count );
	mesh->blend_shapes_fp16 = malloc( sizeof( uint16_t ) * 3 * n * blend_count );
	mesh->blend_shapes_rounded = malloc( sizeof( float ) * 3 * n * blend_count );
	mesh->skin_indices = malloc( sizeof( uint16_t ) * k * n );
	mesh->skin_weights = malloc( sizeof( float ) * k * n );
	mesh->faces = malloc( sizeof( uint32_t ) * 3 * f );
	mesh->adjacency_offsets = malloc( sizeof( uint32_t ) * ( n + 1 ) );
	mesh->adjacency_faces = malloc( sizeof( uint32_t ) * 3 * f );
	mesh->joint_rest = malloc( sizeof( float ) * 3 * j );

	// A tube of radius 0.15 m from y = 0 to y = 1.2 m, slightly wavy so normals vary.
	const float height = 1.2f;
	for ( uint32_t joint = 0; joint < j; ++joint )
	{
		mesh->joint_rest[3 * joint] = 0.0f;
		mesh->joint_rest[3 * joint + 1] = height * (float)joint / (float)( j - 1 );
		mesh->joint_rest[3 * joint + 2] = 0.0f;
	}
	for ( uint32_t r = 0; r < rings; ++r )
	{
		float y = height * (float)r / (float)( rings - 1 );
		for ( uint32_t s = 0; s < segments; ++s )
		{
			float angle = 6.2831853f * (float)s / (float)segments;
			float radius = 0.15f + 0.02f * sinf( 5.0f * y + 3.0f * angle );
			uint32_t v = r * segments + s;
			mesh->shaped_template[3 * v] = radius * cosf( angle );
			mesh->shaped_template[3 * v + 1] = y;
			mesh->shaped_template[3 * v + 2] = radius * sinf( angle );
			// The two nearest chain joints below/above plus their neighbours, hat-function weights.
			float t = y / height * (float)( j - 1 );
			int base = (int)floorf( t ) - 1;
			float weights[4], sum = 0.0f;
			for ( uint32_t i = 0; i < k; ++i )
			{
				int joint = base + (int)i;
				int clamped = joint < 0 ? 0 : ( joint > (int)j - 1 ? (int)j - 1 : joint );
				float distance = fabsf( t - (float)joint );
				weights[i] = distance < 2.0f ? 2.0f - distance : 0.0f;
				weights[i] += 1e-3f;
				sum += weights[i];
				mesh->skin_indices[k * v + i] = (uint16_t)clamped;
			}
			for ( uint32_t i = 0; i < k; ++i )
				mesh->skin_weights[k * v + i] = weights[i] / sum;
		}
	}
	uint32_t face = 0;
	for ( uint32_t r = 0; r + 1 < rings; ++r )
	{
		for ( uint32_t s = 0; s < segments; ++s )
		{
			uint32_t a = r * segments + s, b = r * segments + ( s + 1 ) % segments;
			uint32_t c = a + segments, d = b + segments;
			uint32_t* tri = mesh->faces + 3 * face;
			tri[0] = a, tri[1] = c, tri[2] = b;
			tri[3] = b, tri[4] = c, tri[5] = d;
			face += 2;
		}
	}
	// CSR adjacency, faces ascending within a vertex (as pleat-pack writes NADO/NADF).
	memset( mesh->adjacency_offsets, 0, sizeof( uint32_t ) * ( n + 1 ) );
	for ( uint32_t e = 0; e < 3 * f; ++e )
		mesh->adjacency_offsets[mesh->faces[e] + 1] += 1;
	for ( uint32_t v = 0; v < n; ++v )
		mesh->adjacency_offsets[v + 1] += mesh->adjacency_offsets[v];
	uint32_t* fill = calloc( n, sizeof( uint32_t ) );
	for ( uint32_t tri = 0; tri < f; ++tri )
	{
		for ( uint32_t c = 0; c < 3; ++c )
		{
			uint32_t v = mesh->faces[3 * tri + c];
			mesh->adjacency_faces[mesh->adjacency_offsets[v] + fill[v]++] = tri;
		}
	}
	free( fill );
	uint32_t state = seed * 2654435761u + 1u;
	for ( size_t e = 0; e < (size_t)3 * n * blend_count; ++e )
	{
		mesh->blend_shapes[e] = 0.03f * plTestUniform( &state );
		mesh->blend_shapes_fp16[e] = plTestToHalf( mesh->blend_shapes[e] );
		mesh->blend_shapes_rounded[e] = plTestFromHalf( mesh->blend_shapes_fp16[e] );
	}
}

void plTestMesh_Free( plTestMesh* mesh )
{
	free( mesh->shaped_template );
	free( mesh->blend_shapes );
	free( mesh->blend_shapes_fp16 );
	free( mesh->blend_shapes_rounded );
	free( mesh->skin_indices );
	free( mesh->skin_weights );
	free( mesh->faces );
	free( mesh->adjacency_offsets );
	free( mesh->adjacency_faces );
	free( mesh->joint_rest );
	memset( mesh, 0, sizeof( *mesh ) );
}

// 3×4 affine matrices, row-major: m[r][c] = m[4r + c].
static void plTestMultiply( const double* a, const double* b, double* out )
{
	double result[12];
	for ( int r = 0; r < 3; ++r )
	{
		for ( int c = 0; c < 4; ++c )
		{
			double value = c == 3 ? a[4 * r + 3] : 0.0;
			for ( int i = 0; i < 3; ++i )
				value += a[4 * r + i] * b[4 * i + c];
			result[4 * r + c] = value;
		}
	}
	memcpy( out, result, sizeof( result ) );
}

// Rotation by angle about a unit axis, with translation t.
static void plTestRigid( double angle, double ax, double ay, double az, double tx, double ty, double tz, double* m )
{
	double c = cos( angle ), s = sin( angle ), C = 1.0 - c;
	double rows[12] = {
		c + ax * ax * C,      ax * ay * C - az * s, ax * az * C + ay * s, tx,
		ay * ax * C + az * s, c + ay * ay * C,      ay * az * C - ax * s, ty,
		az * ax * C - ay * s, az * ay * C + ax * s, c + az * az * C,      tz,
	};
	memcpy( m, rows, sizeof( rows ) );
}

void plTestMotion_Frame( const plTestMesh* mesh, uint32_t frame, float* blend_weights, float* skin_matrices )
{
	double t = frame / 30.0;
	for ( uint32_t j = 0; j < mesh->blend_count; ++j )
		blend_weights[j] = (float)( 0.8 * sin( 1.3 * t + 0.7 * j ) * cos( 0.4 * t * ( 1 + j % 5 ) ) );
	// G_0 = T(root) · Rot(R_0) · T(J_0); G_k = G_{k-1} · T(J_k − J_{k-1}) · Rot(R_k); M_k = G_k · T(−J_k).
	double global[12], local[12], skin[12], offset[12];
	plTestRigid( 0.3 * sin( t ), 0.0, 1.0, 0.0, 0.2 * t, 0.05 * sin( 2 * t ), -0.1 * t, global );
	for ( uint32_t k = 0; k < mesh->joint_count; ++k )
	{
		const float* rest = mesh->joint_rest + 3 * k;
		const float* parent = k > 0 ? mesh->joint_rest + 3 * ( k - 1 ) : NULL;
		double bend = 0.25 * sin( 2.1 * t + 0.4 * k );
		double ax = cos( 0.3 * k + t ), az = sin( 0.3 * k + t );
		if ( parent != NULL )
			plTestRigid( bend, ax, 0.0, az, rest[0] - parent[0], rest[1] - parent[1], rest[2] - parent[2], local );
		else
			plTestRigid( bend, ax, 0.0, az, rest[0], rest[1], rest[2], local );
		plTestMultiply( global, local, global );
		plTestRigid( 0.0, 1.0, 0.0, 0.0, -rest[0], -rest[1], -rest[2], offset );
		plTestMultiply( global, offset, skin );
		for ( int e = 0; e < 12; ++e )
			skin_matrices[12 * k + e] = (float)skin[e];
	}
}

void plTestReference_Deform( const plTestMesh* mesh, const float* blend_shapes, const float* blend_weights,
							 const float* skin_matrices, double* positions, double* normals )
{
	const uint32_t n = mesh->vertex_count, k_count = mesh->influence_count;
	for ( uint32_t i = 0; i < n; ++i )
	{
		double x[3];
		for ( int c = 0; c < 3; ++c )
		{
			x[c] = mesh->shaped_template[3 * i + c];
			for ( uint32_t j = 0; j < mesh->blend_count; ++j )
				x[c] += (double)blend_weights[j] * blend_shapes[( (size_t)j * n + i ) * 3 + c];
		}
		double m[12] = { 0.0 }; // Σ_k w_k M_k, then one transform (as skinning.c and the numpy reference)
		for ( uint32_t k = 0; k < k_count; ++k )
		{
			const float* joint = skin_matrices + 12 * mesh->skin_indices[k_count * i + k];
			double w = mesh->skin_weights[k_count * i + k];
			for ( int e = 0; e < 12; ++e )
				m[e] += w * joint[e];
		}
		double p[3];
		for ( int r = 0; r < 3; ++r )
			p[r] = m[4 * r] * x[0] + m[4 * r + 1] * x[1] + m[4 * r + 2] * x[2] + m[4 * r + 3];
		memcpy( positions + 3 * i, p, sizeof( p ) );
	}
	for ( uint32_t i = 0; i < n; ++i )
	{
		double sum[3] = { 0.0, 0.0, 0.0 };
		for ( uint32_t e = mesh->adjacency_offsets[i]; e < mesh->adjacency_offsets[i + 1]; ++e )
		{
			const uint32_t* tri = mesh->faces + 3 * mesh->adjacency_faces[e];
			const double *a = positions + 3 * tri[0], *b = positions + 3 * tri[1], *c = positions + 3 * tri[2];
			double u[3] = { b[0] - a[0], b[1] - a[1], b[2] - a[2] };
			double v[3] = { c[0] - a[0], c[1] - a[1], c[2] - a[2] };
			sum[0] += u[1] * v[2] - u[2] * v[1];
			sum[1] += u[2] * v[0] - u[0] * v[2];
			sum[2] += u[0] * v[1] - u[1] * v[0];
		}
		double length = sqrt( sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2] );
		for ( int c = 0; c < 3; ++c )
			normals[3 * i + c] = length > 0.0 ? sum[c] / length : 0.0;
	}
}

double plTestMaxAbsDiff( const float* a, const double* b, size_t count )
{
	double worst = 0.0;
	for ( size_t i = 0; i < count; ++i )
	{
		double d = fabs( (double)a[i] - b[i] );
		if ( !( d <= worst ) ) // NaN counts as the worst
			worst = isnan( d ) ? INFINITY : d;
	}
	return worst;
}

void plTestMotion_WalkPose( uint32_t frame, float phase_frames, float amplitude, uint32_t joint_count, float* rotations,
							plFrameInput* input )
{
	double t = ( frame + (double)phase_frames ) / 30.0;
	for ( uint32_t k = 0; k < joint_count; ++k )
	{
		double angle = amplitude * sin( 2.0 * t + 0.5 * k ), ax = cos( 0.7 * k ), az = sin( 0.7 * k );
		rotations[4 * k] = (float)( sin( 0.5 * angle ) * ax );
		rotations[4 * k + 1] = 0.0f;
		rotations[4 * k + 2] = (float)( sin( 0.5 * angle ) * az );
		rotations[4 * k + 3] = (float)cos( 0.5 * angle );
	}
	memset( input, 0, sizeof( *input ) );
	input->joint_rotations = rotations;
	input->joint_count = joint_count;
	input->root_translation = ( plVec3 ){ (float)( 0.3 * sin( t ) ), 0.0f, (float)( 1.2 * t ) };
	double yaw = 0.4 * sin( 0.7 * t );
	input->root_rotation = ( plQuat ){ 0.0f, (float)sin( 0.5 * yaw ), 0.0f, (float)cos( 0.5 * yaw ) };
	input->dt_s = 1.0f / 30.0f;
}

int plTestEgl_Create( plTestEglContext* egl )
{
	memset( egl, 0, sizeof( *egl ) );
	const char* client = eglQueryString( EGL_NO_DISPLAY, EGL_EXTENSIONS );
	if ( client == NULL || strstr( client, "EGL_MESA_platform_surfaceless" ) == NULL )
		return 0;
	EGLDisplay display = eglGetPlatformDisplayEXT( EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL );
	if ( display == EGL_NO_DISPLAY || !eglInitialize( display, NULL, NULL ) || !eglBindAPI( EGL_OPENGL_API ) )
		return 0;
	const EGLint attribs[] = { EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 3,
							   EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE };
	EGLContext context = eglCreateContext( display, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attribs );
	if ( context == EGL_NO_CONTEXT )
		return 0;
	egl->display = display;
	egl->context = context;
	return 1;
}

int plTestEgl_MakeCurrent( const plTestEglContext* egl )
{
	return eglMakeCurrent( egl->display, EGL_NO_SURFACE, EGL_NO_SURFACE, egl->context ) == EGL_TRUE;
}

void plTestEgl_Release( const plTestEglContext* egl )
{
	eglMakeCurrent( egl->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT );
}

void plTestEgl_Destroy( plTestEglContext* egl )
{
	if ( egl->context != NULL )
	{
		plTestEgl_Release( egl );
		eglDestroyContext( egl->display, egl->context );
	}
	memset( egl, 0, sizeof( *egl ) );
}

typedef struct plTestBlockHeader
{
	size_t size;
	size_t offset;
} plTestBlockHeader;

static void* plTestAlloc( size_t size, size_t align, void* user )
{
	plTestAllocatorState* state = user;
	size_t offset = align > sizeof( plTestBlockHeader ) ? align : 2 * sizeof( plTestBlockHeader );
	unsigned char* raw = malloc( size + offset + align );
	if ( raw == NULL )
		return NULL;
	uintptr_t aligned = ( (uintptr_t)raw + offset + align - 1 ) & ~(uintptr_t)( align - 1 );
	plTestBlockHeader* header = (plTestBlockHeader*)aligned - 1;
	header->size = size;
	header->offset = aligned - (uintptr_t)raw;
	state->live_bytes += (long long)size;
	state->allocation_count += 1;
	return (void*)aligned;
}

static void plTestFree( void* ptr, size_t size, void* user )
{
	plTestAllocatorState* state = user;
	plTestBlockHeader* header = (plTestBlockHeader*)ptr - 1;
	if ( header->size != size )
		state->size_mismatch = 1;
	state->live_bytes -= (long long)header->size;
	free( (unsigned char*)ptr - header->offset );
}

plAllocator plTestAllocator( plTestAllocatorState* state )
{
	memset( state, 0, sizeof( *state ) );
	return ( plAllocator ){ plTestAlloc, plTestFree, state };
}

double plTestNowSeconds( void )
{
	struct timespec now;
	clock_gettime( CLOCK_MONOTONIC, &now );
	return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}
