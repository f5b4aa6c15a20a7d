-- wrk script: the mesh route on the bundled MakeHuman face, 4 random controls per request
-- (two-sided, values in [-1, 1]), float32 out, so the response cache cannot help.
local controls = {"nose/nose-trans-down|up", "nose/nose-scale-vert-decr|incr", "head/head-age-decr|incr",
                  "mouth/mouth-scale-horiz-decr|incr", "chin/chin-width-decr|incr", "eyes/l-eye-bag-decr|incr",
                  "eyes/r-eye-bag-decr|incr", "cheek/l-cheek-bones-decr|incr", "forehead/forehead-scale-vert-decr|incr",
                  "ears/l-ear-scale-decr|incr", "neck/neck-scale-depth-decr|incr", "eyebrows/eyebrows-trans-down|up"}
local function escape(s) return (s:gsub("[^%w%-._~]", function(c) return string.format("%%%02X", string.byte(c)) end)) end
local route = "mesh"
function init(args)
  if args[1] == "render" then route = "render" end
  math.randomseed(os.time() + (tonumber(tostring({}):sub(8)) or 0))
end
request = function()
  local q, used = {}, {}
  while #q < 4 do
    local c = controls[math.random(#controls)]
    if not used[c] then
      used[c] = true
      q[#q + 1] = "c." .. escape(c) .. "=" .. string.format("%.5f", math.random() * 2 - 1)
    end
  end
  if route == "render" then
    return wrk.format("GET", "/v1/rigs/makehuman/render?" .. table.concat(q, "&") .. "&frame=shapes&width=512&height=512")
  end
  return wrk.format("GET", "/v1/rigs/makehuman/mesh?" .. table.concat(q, "&") .. "&format=f32")
end
