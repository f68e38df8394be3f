// Internal: a tier's mesh carried onto the display mesh (tier_transfer.c), a barycentric map built at scene creation.
// Arrays only: it knows no scene, instance or asset.
#ifndef PLEAT_TIER_TRANSFER_H
#define PLEAT_TIER_TRANSFER_H
#include "pleat/pleat.h"

#include <stddef.h>
#include <stdint.h>

// Each display vertex as a point of one triangle of a tier's mesh in the rest pose: barycentric weights of the closest
// point, plus the signed distance along that triangle's normal. Applied to the tier's deformed positions it gives the
// display vertex's position (the weighted point moved out along the deformed triangle's unit normal) and normal (the
// weighted tier normals, normalised).
typedef struct plTierTransferJob
{
	const float* display_rest;  // [display_count][3] the display mesh's rest positions
	uint32_t display_count;
	const float* tier_rest;     // [tier_count][3]
	uint32_t tier_vertex_count;
	const uint32_t* tier_faces; // [tier_face_count][3]
	uint32_t tier_face_count;
	uint32_t* out_triangles;    // [display_count][3] tier vertex indices
	float* out_weights;         // [display_count][3] barycentric weights (sum 1)
	float* out_offsets;         // [display_count] signed distance along the triangle's normal (metres)
} plTierTransferJob;

plResult plTierTransferJob_Build( const plTierTransferJob* job );
// positions / normals [display_count][3] from the tier's [tier_vertex_count][3] outputs.
void plTierTransfer_Apply( const uint32_t* triangles, const float* weights, const float* offsets, uint32_t display_count,
						   const float* tier_positions, const float* tier_normals, float* out_positions,
						   float* out_normals );

#endif
