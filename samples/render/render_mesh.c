// The body's geometry both renders share (render.c's single character, render_crowd.c's crowd): skinning and normals.
#include "render_mesh.h"

#include <math.h>
#include <string.h>

// x' = Σ_k w_k M_k x with M [J][3][4] row-major, the same LBS the SDK applies to the garment.
void skinBody( const RenderBody* body, const int32_t* body_to_asset, const float* matrices, float* positions )
{
	uint32_t k_count = body->influence_count;
	for ( uint32_t v = 0; v < body->vertex_count; ++v )
	{
		const float* x = body->vertices + v * 3;
		float out[3] = { 0.0f, 0.0f, 0.0f };
		for ( uint32_t k = 0; k < k_count; ++k )
		{
			float w = body->skin_weights[v * k_count + k];
			if ( w == 0.0f )
				continue;
			const float* m = matrices + (size_t)body_to_asset[body->skin_indices[v * k_count + k]] * 12;
			for ( int r = 0; r < 3; ++r )
				out[r] += w * ( m[r * 4 + 0] * x[0] + m[r * 4 + 1] * x[1] + m[r * 4 + 2] * x[2] + m[r * 4 + 3] );
		}
		memcpy( positions + v * 3, out, sizeof( out ) );
	}
}

// Area-weighted vertex normals (the same definition as the SDK's normals job).
void vertexNormals( const float* positions, uint32_t vertex_count, const uint32_t* faces, uint32_t face_count,
					float* normals )
{
	memset( normals, 0, (size_t)vertex_count * 3 * sizeof( float ) );
	for ( uint32_t f = 0; f < face_count; ++f )
	{
		const float* a = positions + faces[f * 3] * 3;
		const float* b = positions + faces[f * 3 + 1] * 3;
		const float* c = positions + faces[f * 3 + 2] * 3;
		float e1[3] = { b[0] - a[0], b[1] - a[1], b[2] - a[2] }, e2[3] = { c[0] - a[0], c[1] - a[1], c[2] - a[2] };
		float n[3] = { e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0] };
		for ( int i = 0; i < 3; ++i )
			for ( int d = 0; d < 3; ++d )
				normals[faces[f * 3 + i] * 3 + d] += n[d];
	}
	for ( uint32_t v = 0; v < vertex_count; ++v )
	{
		float* n = normals + v * 3;
		float length = sqrtf( n[0] * n[0] + n[1] * n[1] + n[2] * n[2] );
		if ( length > 0.0f )
		{
			n[0] /= length;
			n[1] /= length;
			n[2] /= length;
		}
	}
}
