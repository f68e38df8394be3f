#version 430 core
// One Linear layer of f_LP or f_dec for a batch of instances (the MLP job, sdk/src/jobs/mlp.c: plMatVec_Scalar, then
// plApplyActivation on hidden layers; tools/pleat/reference/mlp.py):
//     y[m][r] = act( sum_c W[r][c] * x[m][c] + b[r] )      act: none (the last layer), ReLU or SiLU
// over row r's column window (a packed ensemble's block-diagonal layers skip their zero blocks, as layer_blocks.c
// does). One invocation per output row and PLEAT_LAYER_MEMBERS instances, so each weight read serves all of them;
// the weights are stored transposed, [in][out], so the invocations of a workgroup read consecutive words. The sum runs
// column by column (the CPU kernels keep 8 or 16 partial sums): GPU and CPU agree within the GL tolerance, not bit
// for bit (docs/gpu.md).
layout(local_size_x = 64) in;
#define PLEAT_LAYER_MEMBERS 4

// C twin: plGlNetworkLayer (sdk/src/backends/gl/gl_types.h).
layout(std430, binding = 22) restrict readonly buffer NetworkLayer
{
	uint in_count;       // columns of W: x's width
	uint out_count;      // rows of W: y's width
	uint activation;     // 0 none, 1 ReLU, 2 SiLU (PLEAT_ACTIVATION_*)
	uint weight_fp16;    // 1: two halves per word, row r in the low half of word r / 2 when r is even
	uint output_by_slot; // 1: member m's row goes to NetworkMembers.slots[m] (the decoder's weights, by batch slot)
	uint block_count;    // 0: one window, the whole row
	uint pad0, pad1;
	uvec4 blocks[8];     // (row_begin, row_end, col_begin, col_end), PLEAT_MAX_LAYER_BLOCKS
};
// fp32: [in][out] float bits; fp16: [in][(out + 1) / 2] packed halves.
layout(std430, binding = 20) restrict readonly buffer NetworkWeights { uint weights[]; };
layout(std430, binding = 21) restrict readonly buffer NetworkBias { float bias[]; };                // [out]
// C twin: plGlNetworkMembers. The members of this batch that run their networks, and each one's batch slot.
layout(std430, binding = 25) restrict readonly buffer NetworkMembers
{
	uint member_count;
	uint members_pad0, members_pad1, members_pad2;
	uint slots[];
};
layout(std430, binding = 23) restrict readonly buffer NetworkInput { float inputs[]; };    // [members][in]
layout(std430, binding = 24) restrict writeonly buffer NetworkOutput { float outputs[]; }; // [members or slots][out]

float weight( uint c, uint r )
{
	if ( weight_fp16 != 0u )
	{
		vec2 pair = unpackHalf2x16( weights[c * ( ( out_count + 1u ) / 2u ) + ( r >> 1u )] );
		return ( r & 1u ) != 0u ? pair.y : pair.x;
	}
	return uintBitsToFloat( weights[c * out_count + r] );
}

float activate( float v )
{
	if ( activation == 1u )
		return v > 0.0 ? v : 0.0;
	if ( activation == 2u )
		return v / ( 1.0 + exp( -v ) ); // SiLU: v * sigmoid(v)
	return v;
}

void main()
{
	uint r = gl_GlobalInvocationID.x;
	uint m0 = gl_WorkGroupID.y * PLEAT_LAYER_MEMBERS;
	if ( r >= out_count || m0 >= member_count )
		return;
	uint members = min( uint( PLEAT_LAYER_MEMBERS ), member_count - m0 );
	uint col_begin = 0u, col_end = in_count;
	for ( uint b = 0u; b < block_count; ++b )
	{
		if ( r >= blocks[b].x && r < blocks[b].y )
		{
			col_begin = blocks[b].z;
			col_end = blocks[b].w;
		}
	}
	float sums[PLEAT_LAYER_MEMBERS];
	for ( uint k = 0u; k < uint( PLEAT_LAYER_MEMBERS ); ++k )
		sums[k] = 0.0;
	for ( uint c = col_begin; c < col_end; ++c )
	{
		float w = weight( c, r );
		for ( uint k = 0u; k < members; ++k )
			sums[k] += w * inputs[( m0 + k ) * in_count + c];
	}
	for ( uint k = 0u; k < members; ++k )
	{
		uint row = output_by_slot != 0u ? slots[m0 + k] : m0 + k;
		outputs[row * out_count + r] = activate( sums[k] + bias[r] );
	}
}
