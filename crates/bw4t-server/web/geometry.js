// The map's geometry for drawing and clicking.
//
// /map.json gives zones as top-left boxes in map units, y downwards, doors as boxes on a
// room's edge with the opening each makes, the walls as segments (bw4t-map computes
// them) and the side of a robot's square. From it we derive only the drawing bounds; the openings are drawn as bars when
// the room is occupied.

export function buildMap(json) {
  const zones = json.zones.map((z) => ({
    ...z,
    doors: z.doors || [],
    isRoom: z.kind === 'room',
    isDrop: z.name === json.drop_zone,
  }));
  // Halls may reach beyond `area` (the default map's top halls do): draw everything,
  // with a small margin so that walls on the outer edges show whole.
  const margin = 0.5;
  let [minX, minY, maxX, maxY] = [0, 0, json.area[0], json.area[1]];
  for (const z of zones) {
    minX = Math.min(minX, z.x);
    minY = Math.min(minY, z.y);
    maxX = Math.max(maxX, z.x + z.w);
    maxY = Math.max(maxY, z.y + z.h);
  }
  [minX, minY, maxX, maxY] = [minX - margin, minY - margin, maxX + margin, maxY + margin];
  const openings = new Map(zones.filter((z) => z.isRoom).map((z) => [z.name, z.doors.map((d) => d.opening)]));
  return {
    name: json.name,
    zones,
    byName: new Map(zones.map((z) => [z.name, z])),
    dropZone: json.drop_zone,
    robot: json.robot, // the side of a robot's square
    spawns: json.spawns || [],
    bounds: { x: minX, y: minY, w: maxX - minX, h: maxY - minY },
    walls: json.walls,
    openings,
  };
}

/** The zone under a map point, by the map's own rule (`Map::zone_at`, whose grid is in
 * crates/bw4t-map/src/locate.rs): the first zone in file order (the order of /map.json)
 * whose box holds the point, a box holding its left and top edges but not its right and
 * bottom ones, so that a point on an edge two zones share is in exactly one. The server
 * locates robots by the same rule; tests/web.rs checks that the two agree. */
export function zoneAt(map, x, y) {
  return map.zones.find((z) => x >= z.x && x < z.x + z.w && y >= z.y && y < z.y + z.h) ?? null;
}
