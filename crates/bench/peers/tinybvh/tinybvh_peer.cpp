// tinybvh as a benchmark peer, driven line by line over stdin/stdout by accel-bench
// (accel-bench's `src/suites/common/tinybvh.rs`), so that its timings are taken in the same rounds as ours.
// This file is ours; tinybvh itself is never copied into the repository: `tinybvh.sh`
// beside it takes tiny_bvh.h from the `tinybvh-rs` crate through cargo and compiles this.
//
// Started as `tinybvh_peer SCENE`, where SCENE holds a little-endian u32 triangle count and
// then three (x, y, z, 0) f32 vertices per triangle. Commands, one per line, each answered
// with one line:
//   build            one single-threaded BVH::BuildAVX (binned SAH, tinybvh's default build)
//                    from the triangles into a new BVH: "<seconds> <tinybvh SAH cost>"
//   rebuild          the same into one BVH kept between calls, whose buffers are reused
//   layout NAME      builds and keeps the ray layout NAME (bvh8_cpu, bvh4_cpu, bvh8_cpu_hq):
//                    "<seconds>"
//   rays FILE ANY    loads rays (u32 count, then ox oy oz dx dy dz t_max pad as f32), traced
//                    for the closest hit (ANY = 0) or any hit (ANY = 1): "<set id>"
//   trace ID NAME    traces every ray of set ID once in layout NAME: "<rays per second> <hits>"
//   hits ID N NAME   the first N answers in layout NAME: the closest t, 0 when an any-hit ray
//                    is blocked, -1 for a miss
//   quit

#define TINYBVH_IMPLEMENTATION
// One thread, as the build target asks: tinybvh threads BuildAVX above 50,000
// triangles otherwise.
#define NO_THREADED_BUILDS
#include "tiny_bvh.h"

#include <chrono>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

using namespace tinybvh;

struct RaySet
{
	std::vector<Ray> rays;
	bool anyHit;
};

struct Layout
{
	std::unique_ptr<BVH8_CPU> bvh8;
	std::unique_ptr<BVH4_CPU> bvh4;
	// Closest t, or the ray's own t_max when nothing is nearer.
	void intersect( Ray& r ) const { if (bvh8) bvh8->Intersect( r ); else bvh4->Intersect( r ); }
	bool occluded( const Ray& r ) const { return bvh8 ? bvh8->IsOccluded( r ) : bvh4->IsOccluded( r ); }
};

static double now() { return std::chrono::duration<double>( std::chrono::steady_clock::now().time_since_epoch() ).count(); }

static bool readFile( const std::string& path, std::vector<float>& out, uint32_t floatsPerItem, uint32_t& count )
{
	FILE* f = fopen( path.c_str(), "rb" );
	if (!f) return false;
	bool ok = fread( &count, 4, 1, f ) == 1;
	out.resize( (size_t)count * floatsPerItem );
	ok = ok && fread( out.data(), 4, out.size(), f ) == out.size();
	fclose( f );
	return ok;
}

// Answer of one ray: the closest t (-1 for a miss), or 0 / -1 for blocked / free.
static float answer( const Layout& layout, const RaySet& set, const Ray& ray )
{
	if (set.anyHit) return layout.occluded( ray ) ? 0.0f : -1.0f;
	Ray r = ray;
	layout.intersect( r );
	return r.hit.t < ray.hit.t ? r.hit.t : -1.0f;
}

int main( int argc, char** argv )
{
	if (argc < 2) { fprintf( stderr, "usage: tinybvh_peer SCENE\n" ); return 2; }
	std::vector<float> verts;
	uint32_t triCount = 0;
	if (!readFile( argv[1], verts, 12, triCount ) || triCount == 0) { fprintf( stderr, "cannot read %s\n", argv[1] ); return 2; }
	const bvhvec4* v4 = (const bvhvec4*)verts.data();
	// `verts` is a std::vector<float>: BuildAVX reads vertices as 16-byte vectors, so they
	// are copied to memory tinybvh allocates with that alignment.
	bvhvec4* aligned = (bvhvec4*)malloc64( (size_t)triCount * 3 * sizeof( bvhvec4 ) );
	memcpy( aligned, v4, (size_t)triCount * 3 * sizeof( bvhvec4 ) );
	std::vector<RaySet> sets;
	std::map<std::string, Layout> layouts;
	BVH kept;
	printf( "ready tinybvh %d.%d.%d\n", TINY_BVH_VERSION_MAJOR, TINY_BVH_VERSION_MINOR, TINY_BVH_VERSION_SUB );
	fflush( stdout );
	std::string line;
	while (std::getline( std::cin, line ))
	{
		std::istringstream in( line );
		std::string cmd;
		in >> cmd;
		if (cmd == "quit") break;
		if (cmd == "build" || cmd == "rebuild")
		{
			BVH fresh;
			BVH& bvh = cmd == "build" ? fresh : kept;
			const double t0 = now();
			bvh.BuildAVX( aligned, triCount );
			const double t1 = now();
			printf( "%.9f %.6f\n", t1 - t0, bvh.SAHCost() );
		}
		else if (cmd == "layout")
		{
			std::string name;
			in >> name;
			Layout layout;
			const double t0 = now();
			if (name == "bvh8_cpu") { layout.bvh8 = std::make_unique<BVH8_CPU>(); layout.bvh8->Build( aligned, triCount ); }
			else if (name == "bvh8_cpu_hq") { layout.bvh8 = std::make_unique<BVH8_CPU>(); layout.bvh8->BuildHQ( aligned, triCount ); }
			else if (name == "bvh4_cpu") { layout.bvh4 = std::make_unique<BVH4_CPU>(); layout.bvh4->Build( aligned, triCount ); }
			else { printf( "error unknown layout %s\n", name.c_str() ); fflush( stdout ); continue; }
			printf( "%.9f\n", now() - t0 );
			layouts[name] = std::move( layout );
		}
		else if (cmd == "rays")
		{
			std::string path;
			int any = 0;
			in >> path >> any;
			std::vector<float> raw;
			uint32_t n = 0;
			if (!readFile( path, raw, 8, n )) { printf( "error cannot read %s\n", path.c_str() ); fflush( stdout ); continue; }
			RaySet set;
			set.anyHit = any != 0;
			for (uint32_t i = 0; i < n; i++)
			{
				const float* r = &raw[(size_t)i * 8];
				const float tMax = r[6] < BVH_FAR ? r[6] : BVH_FAR;
				set.rays.push_back( Ray( bvhvec3( r[0], r[1], r[2] ), bvhvec3( r[3], r[4], r[5] ), tMax ) );
			}
			sets.push_back( std::move( set ) );
			printf( "%zu\n", sets.size() - 1 );
		}
		else if (cmd == "trace" || cmd == "hits")
		{
			size_t id = 0, n = 0;
			std::string name;
			in >> id;
			if (cmd == "hits") in >> n;
			in >> name;
			auto found = layouts.find( name );
			if (id >= sets.size() || found == layouts.end()) { printf( "error no such set or layout\n" ); fflush( stdout ); continue; }
			const RaySet& set = sets[id];
			const Layout& layout = found->second;
			if (cmd == "hits")
			{
				std::ostringstream out;
				out.precision( 9 );
				for (size_t i = 0; i < n && i < set.rays.size(); i++) out << answer( layout, set, set.rays[i] ) << ' ';
				printf( "%s\n", out.str().c_str() );
			}
			else
			{
				// Rays are copied from the prepared set, as a renderer would hand over fresh
				// ones: their reciprocal directions are computed once, outside the timing.
				uint32_t hits = 0;
				const double t0 = now();
				for (const Ray& ray : set.rays)
				{
					if (set.anyHit) hits += layout.occluded( ray );
					else { Ray r = ray; layout.intersect( r ); hits += r.hit.t < ray.hit.t; }
				}
				const double t1 = now();
				printf( "%.3f %u\n", set.rays.size() / (t1 - t0), hits );
			}
		}
		else printf( "error unknown command\n" );
		fflush( stdout );
	}
	free64( aligned );
	return 0;
}
