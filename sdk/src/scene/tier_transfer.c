// A tier on another mesh (e.g. a coarser remesh of the garment) carried onto the display mesh, so that every tier of a
// scene has the same vertices and a tier switch can cross-fade vertex by vertex. Built once per tier at scene
// creation: each display vertex is embedded in the tier's rest mesh as the closest point of its closest triangle
// (barycentric weights) plus the signed distance along that triangle's normal. Applied per frame: the weighted tier
// positions moved along the deformed triangle's unit normal, and the weighted tier normals, normalised.
#include "tier_transfer.h"

#include <float.h>
#include <math.h>

static void plSub3( const double* a, const double* b, double* out )
{
	out[0] = a[0] - b[0];
	out[1] = a[1] - b[1];
	out[2] = a[2] - b[2];
}

static double plDot3( const double* a, const double* b )
{
	return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// Barycentric weights (of a, b, c) of the point of triangle abc closest to p, by the triangle's Voronoi regions
// (vertex, edge, face), as in any real-time collision text.
static void plClosestOnTriangle( const double* p, const double* a, const double* b, const double* c, double w[3] )
{
	double ab[3], ac[3], ap[3], bp[3], cp[3];
	plSub3( b, a, ab );
	plSub3( c, a, ac );
	plSub3( p, a, ap );
	double d1 = plDot3( ab, ap ), d2 = plDot3( ac, ap );
	if ( d1 <= 0.0 && d2 <= 0.0 )
	{
		w[0] = 1.0, w[1] = 0.0, w[2] = 0.0;
		return;
	}
	plSub3( p, b, bp );
	double d3 = plDot3( ab, bp ), d4 = plDot3( ac, bp );
	if ( d3 >= 0.0 && d4 <= d3 )
	{
		w[0] = 0.0, w[1] = 1.0, w[2] = 0.0;
		return;
	}
	double vc = d1 * d4 - d3 * d2;
	if ( vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 )
	{
		double t = d1 / ( d1 - d3 );
		w[0] = 1.0 - t, w[1] = t, w[2] = 0.0;
		return;
	}
	plSub3( p, c, cp );
	double d5 = plDot3( ab, cp ), d6 = plDot3( ac, cp );
	if ( d6 >= 0.0 && d5 <= d6 )
	{
		w[0] = 0.0, w[1] = 0.0, w[2] = 1.0;
		return;
	}
	double vb = d5 * d2 - d1 * d6;
	if ( vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 )
	{
		double t = d2 / ( d2 - d6 );
		w[0] = 1.0 - t, w[1] = 0.0, w[2] = t;
		return;
	}
	double va = d3 * d6 - d5 * d4;
	if ( va <= 0.0 && ( d4 - d3 ) >= 0.0 && ( d5 - d6 ) >= 0.0 )
	{
		double t = ( d4 - d3 ) / ( ( d4 - d3 ) + ( d5 - d6 ) );
		w[0] = 0.0, w[1] = 1.0 - t, w[2] = t;
		return;
	}
	double denom = 1.0 / ( va + vb + vc );
	w[1] = vb * denom;
	w[2] = vc * denom;
	w[0] = 1.0 - w[1] - w[2];
}

static void plLoad3( const float* v, uint32_t i, double* out )
{
	out[0] = v[(size_t)i * 3 + 0];
	out[1] = v[(size_t)i * 3 + 1];
	out[2] = v[(size_t)i * 3 + 2];
}

plResult plTierTransferJob_Build( const plTierTransferJob* job )
{
	if ( job == NULL || job->display_rest == NULL || job->tier_rest == NULL || job->tier_faces == NULL ||
		 job->tier_face_count == 0 || job->out_triangles == NULL || job->out_weights == NULL ||
		 job->out_offsets == NULL )
	{
		return PLEAT_RESULT_INVALID_ARGUMENT;
	}
	for ( uint32_t f = 0; f < job->tier_face_count * 3; ++f )
	{
		if ( job->tier_faces[f] >= job->tier_vertex_count )
		{
			return PLEAT_RESULT_INVALID_ARGUMENT;
		}
	}
	for ( uint32_t v = 0; v < job->display_count; ++v )
	{
		double p[3], best_w[3] = { 1.0, 0.0, 0.0 }, best_d2 = DBL_MAX;
		uint32_t best_f = 0;
		plLoad3( job->display_rest, v, p );
		for ( uint32_t f = 0; f < job->tier_face_count; ++f )
		{
			const uint32_t* t = job->tier_faces + (size_t)f * 3;
			double a[3], b[3], c[3], w[3];
			plLoad3( job->tier_rest, t[0], a );
			plLoad3( job->tier_rest, t[1], b );
			plLoad3( job->tier_rest, t[2], c );
			plClosestOnTriangle( p, a, b, c, w );
			double d2 = 0.0;
			for ( int k = 0; k < 3; ++k )
			{
				double q = w[0] * a[k] + w[1] * b[k] + w[2] * c[k] - p[k];
				d2 += q * q;
			}
			if ( d2 < best_d2 )
			{
				best_d2 = d2, best_f = f;
				best_w[0] = w[0], best_w[1] = w[1], best_w[2] = w[2];
			}
		}
		const uint32_t* t = job->tier_faces + (size_t)best_f * 3;
		double a[3], b[3], c[3], ab[3], ac[3], n[3], q[3];
		plLoad3( job->tier_rest, t[0], a );
		plLoad3( job->tier_rest, t[1], b );
		plLoad3( job->tier_rest, t[2], c );
		plSub3( b, a, ab );
		plSub3( c, a, ac );
		n[0] = ab[1] * ac[2] - ab[2] * ac[1];
		n[1] = ab[2] * ac[0] - ab[0] * ac[2];
		n[2] = ab[0] * ac[1] - ab[1] * ac[0];
		double length = sqrt( plDot3( n, n ) );
		for ( int k = 0; k < 3; ++k )
		{
			q[k] = p[k] - ( best_w[0] * a[k] + best_w[1] * b[k] + best_w[2] * c[k] );
		}
		for ( int k = 0; k < 3; ++k )
		{
			job->out_triangles[(size_t)v * 3 + k] = t[k];
			job->out_weights[(size_t)v * 3 + k] = (float)best_w[k];
		}
		job->out_offsets[v] = length > 0.0 ? (float)( plDot3( q, n ) / length ) : 0.0f;
	}
	return PLEAT_RESULT_OK;
}

void plTierTransfer_Apply( const uint32_t* triangles, const float* weights, const float* offsets, uint32_t display_count,
						   const float* tier_positions, const float* tier_normals, float* out_positions,
						   float* out_normals )
{
	for ( uint32_t v = 0; v < display_count; ++v )
	{
		const uint32_t* t = triangles + (size_t)v * 3;
		const float* w = weights + (size_t)v * 3;
		const float *a = tier_positions + (size_t)t[0] * 3, *b = tier_positions + (size_t)t[1] * 3,
					*c = tier_positions + (size_t)t[2] * 3;
		float ab[3] = { b[0] - a[0], b[1] - a[1], b[2] - a[2] }, ac[3] = { c[0] - a[0], c[1] - a[1], c[2] - a[2] };
		float n[3] = { ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2], ab[0] * ac[1] - ab[1] * ac[0] };
		float length = sqrtf( n[0] * n[0] + n[1] * n[1] + n[2] * n[2] );
		float along = length > 0.0f ? offsets[v] / length : 0.0f;
		float m[3] = { 0.0f, 0.0f, 0.0f };
		for ( int k = 0; k < 3; ++k )
		{
			out_positions[(size_t)v * 3 + k] = w[0] * a[k] + w[1] * b[k] + w[2] * c[k] + along * n[k];
			for ( int j = 0; j < 3; ++j )
			{
				m[k] += w[j] * tier_normals[(size_t)t[j] * 3 + k];
			}
		}
		float ml = sqrtf( m[0] * m[0] + m[1] * m[1] + m[2] * m[2] );
		for ( int k = 0; k < 3; ++k )
		{
			out_normals[(size_t)v * 3 + k] = ml > 0.0f ? m[k] / ml : 0.0f;
		}
	}
}
