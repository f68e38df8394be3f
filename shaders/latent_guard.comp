#version 430 core
// The latent guard between f_LP and f_dec for a batch (sdk/src/jobs/latent_guard.c and the step's finite check before
// it, sdk/src/instance/instance_step.c plRunNetworks):
//     finite[m] = every y[m][i] is finite
//     Z[m][i]   = clamp( y[m][i] * z_std[i] + z_mean[i], z_min[i], z_max[i] )   (0 where y[m] is not all finite)
// The CPU reads finite[m] back: a member whose y is not finite takes the numeric reset, as on the CPU path (the clamp
// would turn an overflow into a bound). One invocation per member.
layout(local_size_x = 64) in;

// C twin: plGlNetworkLayer (only in_count, the latent width L, is read).
layout(std430, binding = 22) restrict readonly buffer NetworkLayer { uint latent_count; };
layout(std430, binding = 25) restrict readonly buffer NetworkMembers { uint member_count; };
layout(std430, binding = 23) restrict readonly buffer NetworkInput { float y[]; };   // [members][L]
layout(std430, binding = 24) restrict writeonly buffer NetworkOutput { float z[]; }; // [members][L]
layout(std430, binding = 26) restrict readonly buffer LatentRange { vec4 ranges[]; }; // [L] (mean, std, min, max)
layout(std430, binding = 27) restrict writeonly buffer NetworkFinite { uint finite[]; }; // [members] 1 or 0

// Bit test rather than isinf / isnan, which a driver's fast-math may fold away.
bool is_finite( float v )
{
	return ( floatBitsToUint( v ) & 0x7f800000u ) != 0x7f800000u;
}

void main()
{
	uint m = gl_GlobalInvocationID.x;
	if ( m >= member_count )
		return;
	uint base = m * latent_count;
	bool all_finite = true;
	for ( uint i = 0u; i < latent_count; ++i )
		all_finite = all_finite && is_finite( y[base + i] );
	for ( uint i = 0u; i < latent_count; ++i )
	{
		vec4 range = ranges[i];
		float v = y[base + i] * range.y + range.x;
		v = v < range.z ? range.z : v;
		v = v > range.w ? range.w : v;
		z[base + i] = all_finite ? v : 0.0;
	}
	finite[m] = all_finite ? 1u : 0u;
}
